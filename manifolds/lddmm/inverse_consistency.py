"""Inverse consistency of a landmark space's registrations (paper, Table 1)."""

from __future__ import annotations

from collections.abc import Callable

from ..point_distance import point_distance

__all__ = ["inverse_consistency"]


def inverse_consistency(space, template, shape, distance: str | Callable = "rms") -> float:
    """Inverse consistency error of the registrations between ``template`` and ``shape``.

    With ``phi_TS`` the deformation registering ``T`` onto ``S`` and ``phi_ST``
    the one registering ``S`` onto ``T`` (each from its own template's control
    points), returns ``d(phi_ST(phi_TS(T)), T)``, how far the composition is from
    the identity on ``T``. It is zero when ``phi_ST = phi_TS^{-1}`` on ``T``.

    Parameters
    ----------
    space : KernelLandmarkSpace
        Registers (``space.register``, cached) and flows points (``space.flow``).
    template, shape : arrays, shape ``(k, d)``
    distance : {"rms", "frobenius", "mean"} or callable, default "rms"
        Per-vertex RMS distance ``||A - B||_F / sqrt(k)`` (the paper's unit),
        Frobenius norm, mean per-vertex distance, or ``(a, b) -> float``
        (:func:`manifolds.point_distance.point_distance`).

    Returns
    -------
    float
    """
    template = space.check_point(template, "template")
    shape = space.check_point(shape, "shape")
    dist = point_distance(distance, space.point_shape)
    forward = space.register(template, shape)
    backward = space.register(shape, template)
    back = space.flow(
        shape, backward.momenta, forward.deformed, control_points=backward.control_points
    )
    return float(dist(back, template))
