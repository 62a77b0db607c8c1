"""The LDDMM landmark space: shapes as point sets deformed by Gaussian-kernel flows.

Paper, Section 2.1. A point is a shape ``T`` of ``k`` landmarks in ``R^d``
(e.g. the vertices of a mesh, in correspondence across shapes). A tangent
vector at ``T`` is a set of initial momenta ``mu`` at the control points
``c(T)`` chosen by the control-point policy; ``Exp_T(mu) = phi_1(T)`` is the
flow of the geodesic shot from ``(c(T), mu)`` and ``Log_T(S)`` is the
registration of ``T`` onto ``S`` (eq. 3), which is inexact for ``alpha > 0``:
``S = Exp_T(Log_T S) + delta`` (eq. 4).
"""

from __future__ import annotations

import numpy as np

from ..numerics.integrators import Integrator
from ..validation import check_array, check_finite_result
from .control_points import is_dense
from .hamiltonian_shooting import HamiltonianFlow, shoot
from .hamiltonian_system import hamiltonian_system
from .landmark_space import KernelLandmarkSpace
from .tangent import LandmarkTangent

__all__ = ["LDDMMLandmarks"]


class LDDMMLandmarks(KernelLandmarkSpace):
    """Landmark shapes ``(k, d)`` with the LDDMM exponential and registration as logarithm.

    ``Exp_T(mu) = phi_1(T)`` is Hamiltonian shooting from ``(c(T), mu)`` (eq. 2);
    ``Log_T(S)`` is the registration of eq. (3), over the momenta or, with
    ``optimize_control_points``, over the control points and the momenta. The
    parameters are those of
    :class:`~manifolds.lddmm.landmark_space.KernelLandmarkSpace` (``n_landmarks,
    dim, sigma, alpha, settings, cache_size, block_size`` and keyword overrides of
    the :class:`~manifolds.lddmm.RegistrationSettings`); the integrator defaults
    to ``"euler"``.
    """

    flow_model = HamiltonianFlow

    # ------------------------------------------------------------ deformation model
    def shoot(
        self,
        template,
        momenta,
        control_points=None,
        return_trajectory: bool = False,
        integrator: str | Integrator | None = None,
    ):
        """Deformed template ``phi_1(T)`` for the geodesic shot from ``(c, momenta)``.

        Parameters
        ----------
        template : array, shape ``(k, d)``
        momenta : array, shape ``(n_cp, d)``
        control_points : array, shape ``(n_cp, d)``, optional
            Defaults to the policy's control points of ``template``.
        return_trajectory : bool
            Also return the list of ``n_steps + 1`` states ``(c, mu, x)`` (for
            dense control points, :func:`~manifolds.lddmm.control_points.is_dense`,
            the template is carried as ``c``, and the states are ``(c, mu)``).
        integrator : optional
            Overrides the space's integrator.
        """
        template = self.check_point(template, "template")
        if control_points is None:
            cp = self.control_points(template)
        else:
            cp = check_array(control_points, (self.point_shape[1],), f"{self.name}: control_points")
        momenta = self._check_momenta(cp, momenta, "momenta")
        dense = is_dense(template, cp)
        res = shoot(
            self.kernel,
            cp,
            momenta,
            self.integrator if integrator is None else integrator,
            self.n_steps,
            points=None if dense else template,
            return_trajectory=return_trajectory,
        )
        deformed = res.control_points if dense else res.points
        check_finite_result(
            deformed,
            f"{self.name}: momenta (tangent)",
            f"the shooting diverged (largest momentum {np.max(np.abs(momenta)):.4g}, "
            f"sigma {self.sigma:g}): momenta too large for the kernel width",
        )
        return (deformed, res.trajectory) if return_trajectory else deformed

    def geodesic_step(self, control_points, momenta, h: float):
        """One step of size ``h`` of the geodesic equations of ``(c, mu)`` (eq. 2).

        The step of the space's own integrator on the Hamiltonian system that
        :meth:`shoot` integrates: ``n`` steps of size ``1/n`` from ``(c, mu)`` give
        the control points and momenta of ``shoot`` with ``n_steps = n``. The
        fanning scheme (:func:`ladders.fanning_scheme`) shoots with it.

        Returns
        -------
        control_points, momenta : arrays, shape ``(n_cp, d)``
        """
        system = hamiltonian_system(self.kernel)
        state = system.to_layout(control_points, momenta)
        (c, mu), _ = self.integrator.step(system.rhs, state, float(h))
        d = np.shape(control_points)[1]
        return system.from_layout(c, d), system.from_layout(mu, d)

    def flow(self, template, momenta, points, control_points=None) -> np.ndarray:
        """``phi_1(points)`` for the deformation shot from the template's control points."""
        cp, momenta, pts = self._flow_inputs(template, momenta, points, control_points)
        res = shoot(self.kernel, cp, momenta, self.integrator, self.n_steps, points=pts)
        return res.points

    def exp(self, point, tangent):
        """``Exp_T(mu) = phi_1(T)``, shot from the tangent's control points.

        ``tangent`` is a :class:`LandmarkTangent` or momenta ``(n_cp, d)`` at ``c(T)``.
        """
        point = self.check_point(point, "point")
        if isinstance(tangent, LandmarkTangent):
            cp, momenta = self._split_tangent(point, tangent, "tangent")
            return self.shoot(point, momenta, control_points=cp)
        cp = self.control_points(point)
        tangent = self._check_momenta(cp, tangent, "tangent")
        return self.shoot(point, tangent, control_points=None)
