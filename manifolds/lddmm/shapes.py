"""Smooth random landmark shapes: the LDDMM space's ``random_point``."""

from __future__ import annotations

import numpy as np

from ..errors import ManifoldError
from ..validation import check_int, check_rng

__all__ = ["random_shape"]


def random_shape(rng: np.random.Generator, n_landmarks: int, dim: int) -> np.ndarray:
    """A perturbed ellipse (``dim = 2``) or ellipsoid (``dim = 3``) of ``n_landmarks`` points.

    The landmarks are spread evenly on the unit circle or sphere (Fibonacci
    lattice), scaled to semi-axes ``(1, 0.7[, 0.5])`` perturbed by 5 %, with a
    smooth random radial modulation of about 5 % and a small translation.

    Parameters
    ----------
    rng : numpy.random.Generator
    n_landmarks : int
    dim : {2, 3}

    Returns
    -------
    array, shape ``(n_landmarks, dim)``
    """
    check_rng(rng)
    k = check_int(n_landmarks, "n_landmarks", minimum=1)
    d = check_int(dim, "dim", minimum=2)
    if d > 3:
        raise ManifoldError(f"dim: expected 2 or 3, got {dim!r}")
    if d == 2:
        theta = 2 * np.pi * (np.arange(k) + rng.uniform()) / k
        u = np.stack([np.cos(theta), np.sin(theta)], axis=1)
        axes = np.array([1.0, 0.7])
    else:
        i = np.arange(k) + 0.5
        z = 1 - 2 * i / k
        phi = np.pi * (1 + 5**0.5) * i + 2 * np.pi * rng.uniform()
        r = np.sqrt(np.maximum(1 - z**2, 0.0))
        u = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
        axes = np.array([1.0, 0.7, 0.5])
    axes = axes * (1 + 0.05 * rng.standard_normal(d))
    lin = rng.standard_normal(d)
    quad = rng.standard_normal((d, d))
    radial = 1 + 0.05 * (u @ lin + np.einsum("ki,ij,kj->k", u, quad + quad.T, u) / 2)
    return u * axes * radial[:, None] + 0.05 * rng.standard_normal(d)
