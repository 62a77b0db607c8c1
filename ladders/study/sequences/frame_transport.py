"""Every frame of a subject's cycle transported to the atlas with the pole ladder.

A subject's cycle is a sequence of shapes ``S_0 = S`` (end-diastole), ``S_1``, ...,
``S_{n-1}``, in vertex correspondence with the atlas ``T``. The deformation of frame
``t`` is ``Log_S(S_t)`` (ED to frame ``t``); the paper's Algorithm 1 carries it to the
atlas with one rung of the pole ladder,

    ``M = Exp_T(1/2 Log_T(S))``,  ``T''_t = s_M(S_t)``,  ``T'_t = s_T(T''_t)``,

so ``T'_t = s_T o s_M (S_t)`` is the atlas moved as the subject moves at frame ``t``.
The midpoint ``M`` is shared by every frame; each frame costs two registrations
(``Log_M(S_t)`` and ``Log_T(T''_t)``), as one pair of the ED-ES study does
(:func:`~ladders.study.running.pipeline.compute_pair`): frame ``t`` of a cycle is the
study's pair ``(S, S_t)``, and the frame at end-systole gives the study's pole ladder.
The residual-augmented space (``S = phi_1(T) + delta``) is the default, as in the
study: without residuals the transported frames keep only what the deformations reach.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from manifolds.residual import ResidualAugmented

__all__ = ["FrameTransport", "check_frames", "transport_frames"]


@dataclass(frozen=True)
class FrameTransport:
    """The pole-ladder transport of one subject's frames to the atlas.

    Attributes
    ----------
    transported : ndarray, shape (n_frames, k, 3)
        ``T'_t``; ``transported[0]`` is the atlas (frame 0 is ED).
    registration_rms : ndarray, shape (n_frames,)
        Per-vertex RMS distance between ``S_t`` and its reconstruction from
        ``Log_M(S_t)`` without the residual (what the deformations do not reach; 0 for
        frame 0).
    converged : ndarray of bool, shape (n_frames,)
        Whether the registrations of the frame converged.
    seconds : float
    """

    transported: np.ndarray
    registration_rms: np.ndarray
    converged: np.ndarray
    seconds: float

    @property
    def displacement(self) -> np.ndarray:
        """``T'_t - T``, shape ``(n_frames, k, 3)``."""
        return self.transported - self.transported[0]


def check_frames(frames, n_vertices: int | None = None, name: str = "frames") -> np.ndarray:
    """``frames`` as a float64 array ``(n_frames, k, 3)``, or a ValueError naming what is wrong.

    At least two frames, every coordinate finite, and ``k == n_vertices`` when given.
    """
    try:
        x = np.asarray(frames, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected an array of shape (n_frames, k, 3)") from None
    if x.ndim != 3 or x.shape[2] != 3:
        raise ValueError(f"{name}: expected shape (n_frames, k, 3), got {x.shape}")
    if x.shape[0] < 2:
        raise ValueError(f"{name}: expected at least 2 frames (ED and one more), got {x.shape[0]}")
    if n_vertices is not None and x.shape[1] != n_vertices:
        raise ValueError(
            f"{name}: {x.shape[1]} vertices per frame, the atlas has {n_vertices} "
            "(the frames must be in the atlas's vertex correspondence)"
        )
    bad = ~np.isfinite(x).all(axis=(1, 2))
    if bad.any():
        raise ValueError(f"{name}: frame(s) {np.flatnonzero(bad).tolist()} contain NaN or inf")
    return x


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=-1))))


def transport_frames(
    space, atlas, frames, use_residuals: bool = True, model=None
) -> FrameTransport:
    """Transport every frame's deformation ``Log_S(S_t)`` to ``atlas`` (see the module).

    Parameters
    ----------
    space : manifolds.Connection
        The space of a deformation model (:func:`~ladders.study.running.pipeline.make_space`);
        the landmark spaces cache their registrations, so the midpoint is computed once.
    atlas : array, shape (k, 3)
        The atlas ``T``.
    frames : array, shape (n_frames, k, 3)
        The subject's frames, ED first, in the atlas's vertex correspondence.
    use_residuals : bool, default True
        The residual-augmented space (the study's "pole ladder, with residuals").
    model : DeformationModel, optional
        The model of ``space`` (:class:`~ladders.study.deformations.DeformationModel`),
        whose ``residual_space`` and ``register`` are used; without it, ``space`` is a
        landmark space (:class:`~manifolds.lddmm.KernelLandmarkSpace`) and its own are.

    Returns
    -------
    FrameTransport
    """
    start = time.perf_counter()
    t = np.asarray(atlas, dtype=np.float64)
    x = check_frames(frames, len(t))
    if model is None:
        sp, register = ResidualAugmented(space, use_residuals=use_residuals), space.register
    else:
        sp = model.residual_space(space, use_residuals=use_residuals)

        def register(template, target):
            return model.register(space, template, target)

    m = sp.midpoint(t, x[0])  # M = Exp_T(1/2 Log_T(S)), one registration
    n = len(x)
    transported = np.empty_like(x)
    transported[0] = t
    rms, converged = np.zeros(n), np.ones(n, dtype=bool)
    for k in range(1, n):
        reflected = sp.symmetry(m, x[k])  # T'' = s_M(S_t)
        transported[k] = sp.symmetry(t, reflected)  # T' = s_T(T'')
        reg = register(m, x[k])
        rms[k] = _rms(reg.deformed, x[k])
        converged[k] = bool(reg.converged) and bool(register(t, reflected).converged)
    return FrameTransport(transported, rms, converged, time.perf_counter() - start)
