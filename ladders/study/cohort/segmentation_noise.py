"""Segmentation noise: a smooth random displacement of a surface along its normals.

A segmentation's surface differs from the true one by an error that is smooth
along the wall (a few millimetres of correlation length, from the image's
resolution and the segmentation tool's regularisation) and mostly normal to it.
:func:`smooth_normal_noise` draws such an error: a random field on the surface,
a sum of Gaussian bumps of width ``length`` centred on random vertices with
normal random amplitudes, scaled to the requested RMS ``amplitude`` over the
vertices, applied along the area-weighted vertex normals.
"""

from __future__ import annotations

import numpy as np
import trimesh

from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.validation import check_float, check_rng

__all__ = ["smooth_normal_noise"]


def smooth_normal_noise(
    vertices,
    faces,
    amplitude: float,
    rng: np.random.Generator,
    length: float = 10.0,
    n_bumps: int = 64,
) -> np.ndarray:
    """``vertices`` displaced along their normals by a smooth random field of RMS ``amplitude``.

    Parameters
    ----------
    vertices : array, shape (k, 3)
        In mm.
    faces : int array, shape (f, 3)
    amplitude : float
        RMS of the normal displacement over the vertices, in mm (0 returns a copy).
    rng : numpy.random.Generator
    length : float, default 10.0
        Width of the field's bumps (its correlation length), in mm.
    n_bumps : int, default 64
        Number of bumps (at most ``k``).

    Returns
    -------
    ndarray, shape (k, 3)
    """
    v, f = check_mesh(vertices, faces, "smooth_normal_noise: mesh")
    amplitude = check_float(amplitude, "smooth_normal_noise: amplitude", minimum=0.0)
    length = check_float(length, "smooth_normal_noise: length", minimum=0.0)
    check_rng(rng)
    if amplitude == 0.0:
        return v.copy()
    if length == 0.0:
        raise ValueError("smooth_normal_noise: length: expected a correlation length > 0 mm")
    centres = v[rng.choice(len(v), size=min(int(n_bumps), len(v)), replace=False)]
    weights = rng.standard_normal(len(centres))
    d2 = ((v[:, None, :] - centres[None, :, :]) ** 2).sum(axis=-1)
    field = np.exp(-d2 / length**2) @ weights
    field -= field.mean()
    rms = np.sqrt(np.mean(field**2))
    if rms == 0.0:
        return v.copy()
    normals = np.asarray(trimesh.Trimesh(v, f, process=False).vertex_normals, dtype=float)
    return v + (amplitude / rms) * field[:, None] * normals
