"""The LDDMM model of the study (:class:`manifolds.lddmm.LDDMMLandmarks`), registered as ``lddmm``.

Registered the way a user's model is (:func:`~.registry.register_deformation` when this
module is imported). Its own transport is the fanning scheme: ``Log_S(S')`` carried along
the geodesic ``S -> T`` as a Jacobi field (:func:`ladders.fanning.fanning_transport`),
then the atlas shot with it.
"""

from __future__ import annotations

import numpy as np

from manifolds.lddmm import LDDMMLandmarks

from ...fanning import fanning_transport
from .model import FANNING, DeformationModel, Registration, Transported
from .registry import register_deformation

__all__ = ["KernelModel", "LDDMMModel", "at_control_points"]


class KernelModel(DeformationModel):
    """What the kernel landmark models (LDDMM, SVF) share: their space built from the
    study's registration settings, their registration and inverse consistency.

    Attributes
    ----------
    space_class : type
        A :class:`manifolds.lddmm.KernelLandmarkSpace` subclass.
    """

    space_class = None

    def make_space(self, template, alpha2, settings):
        """The kernel space at ``alpha = sqrt(alpha2)``.

        With the ``"vertices"`` policy the sample of vertices is drawn once, on
        ``template`` (the atlas), and used for every shape of the study
        (:meth:`~manifolds.lddmm.RegistrationSettings.fix_control_point_indices`): the
        control points are the same material points on ``T``, ``S``, ``S'``, ``M`` and
        the reflected shapes.
        """
        k, d = np.shape(template)
        return self.space_class(
            n_landmarks=k,
            dim=d,
            alpha=float(np.sqrt(alpha2)),
            settings=settings.fix_control_point_indices(template),
        )

    def register(self, space, template, target) -> Registration:
        """The space's registration (eq. 3), cached: the pole ladder's ``Log_T(S)`` reuses it."""
        reg = space.register(template, target)
        return Registration(reg.deformed, float(reg.rms_error), float(reg.rkhs_norm),
                            bool(reg.converged))  # fmt: skip

    def inverse_consistency(self, space, template, shape, distance="rms") -> float:
        """:meth:`manifolds.lddmm.KernelLandmarkSpace.inverse_consistency`."""
        return float(space.inverse_consistency(template, shape, distance=distance))


def at_control_points(space, atlas, control_points, momenta) -> np.ndarray | None:
    """Momenta at ``c(T)`` whose velocity there equals that of ``momenta`` at ``control_points``.

    The fanning scheme's momenta live at the control points it carried along the
    geodesic ``S -> T``, close to but not at the atlas's own: the kernel field they
    define is sampled at ``c(T)`` and solved back to momenta there (the RKHS
    projection), so that every subject's tangent is at the same control points.
    None with optimised control points (no fixed ``c(T)``).
    """
    if space.optimize_control_points:
        return None
    cp = space.control_points(atlas)
    velocity = space.kernel.convolve(cp, np.asarray(control_points), np.asarray(momenta))
    return space.kernel_solve(cp, velocity)


class LDDMMModel(KernelModel):
    """LDDMM geodesics on landmarks (:class:`manifolds.lddmm.LDDMMLandmarks`); its own
    transport is the fanning scheme."""

    name = "lddmm"
    label = "LDDMM"
    space_class = LDDMMLandmarks
    transport_method = FANNING
    transport_label = "fanning scheme"
    optimizes_control_points = True

    def transport(self, space, atlas, subject, follow_up, n_steps: int) -> Transported:
        """Transport ``Log_S(S')`` along the geodesic ``S -> T``, then shoot the atlas with it."""
        fan = fanning_transport(space, subject, atlas, space.log(subject, follow_up),
                                n_steps=n_steps)  # fmt: skip
        moved = space.shoot(atlas, fan.momenta, control_points=fan.control_points)
        return Transported(moved, at_control_points(space, atlas, fan.control_points, fan.momenta))


register_deformation(LDDMMModel())
