"""The SVF landmark space: shapes deformed by flows of stationary kernel fields.

A point is a shape ``T`` of ``k`` landmarks in ``R^d``. A tangent vector at
``T`` is a stationary velocity field ``v(x) = sum_j K(x, c_j) m_j`` given by its
momenta ``m`` at the control points ``c(T)`` of the control-point policy; the
control points and momenta do not move in time. ``Exp_T(v) = exp(v)(T)`` is the
time-one flow of ``v`` (the group exponential) and ``Log_T(S)`` the SVF
registration of ``T`` onto ``S``, inexact for ``alpha > 0``:
``S = Exp_T(Log_T S) + delta`` as in the paper's eq. (4), so that
:class:`manifolds.ResidualAugmented` wraps this space unchanged.

Differences with :class:`~manifolds.lddmm.LDDMMLandmarks`: the field is not a
geodesic of the kernel metric (no momentum/control-point evolution), and
``exp(v)^{-1} = exp(-v)`` exactly for the flow (up to the integrator's error).
See ``docs/svf.md``.
"""

from __future__ import annotations

import numpy as np

from .landmark_space import KernelLandmarkSpace
from .stationary_flow import StationaryFlow, StationaryKernelFlow, kernel_flow

__all__ = ["SVFLandmarks"]


class SVFLandmarks(KernelLandmarkSpace):
    """Landmark shapes ``(k, d)`` with the SVF group exponential and registration as logarithm.

    ``Exp_T(v) = exp(v)(T)`` is the flow for unit time of the stationary field
    ``v(x) = sum_k K(x, c_k) m_k`` (control points and momenta fixed in time);
    ``Log_T(S)`` minimises ``||S - exp(v)(T)||^2 + alpha^2 ||v||_V^2``. The
    parameters are those of
    :class:`~manifolds.lddmm.landmark_space.KernelLandmarkSpace`; the integrator
    defaults to ``"rk4"``.
    """

    flow_model = StationaryKernelFlow

    # ------------------------------------------------------------ deformation model
    def deformation(self, point, tangent) -> StationaryFlow:
        """``exp(v)`` for the field of momenta ``tangent`` at ``c(point)``, as a map on points."""
        cp, tangent = self._split_tangent(point, tangent, "tangent")
        return StationaryFlow.from_momenta(
            self.kernel, cp.copy(), tangent.copy(), self.integrator, self.n_steps
        )

    def flow(self, template, momenta, points, control_points=None) -> np.ndarray:
        """``exp(v)(points)`` for the field of ``momenta`` at ``control_points``
        (default ``c(template)``), shape ``(n, d)``."""
        cp, momenta, pts = self._flow_inputs(template, momenta, points, control_points)
        return kernel_flow(self.kernel, cp, momenta, pts, self.integrator, self.n_steps).points

    def exp(self, point, tangent):
        """``Exp_T(v) = exp(v)(T)``; ``tangent`` is the momenta at ``c(T)``, ``(n_cp, d)``."""
        point = self.check_point(point, "point")
        cp, tangent = self._split_tangent(point, tangent, "tangent")
        if not tangent.any():
            return point.copy()
        return kernel_flow(self.kernel, cp, tangent, point, self.integrator, self.n_steps).points
