"""The outcome of a registration: :class:`RegistrationResult` (its own module, below the drivers).

The registration drivers (:mod:`manifolds.lddmm.registration`,
:mod:`manifolds.lddmm.svf_registration`) and the problem the solvers see
(:mod:`manifolds.lddmm.registration_problem`) all build it; it depends on none of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["RegistrationResult"]


@dataclass
class RegistrationResult:
    """Outcome of a registration of ``template`` onto a target.

    Attributes
    ----------
    momenta : array, shape ``(n_cp, d)``
        Initial momenta ``mu`` (the logarithm ``Log_T(S)``).
    control_points : array, shape ``(n_cp, d)``
    deformed : array, shape ``(k, d)``
        ``phi_1(T)``.
    residual : array, shape ``(k, d)``, or None
        ``delta = S - phi_1(T)`` (paper, eq. 4) for a target in correspondence;
        None for data terms without correspondence.
    objective : float
        Final value of ``C(c, mu)`` (eq. 3).
    registration_error : float
        ``sqrt(D(phi_1(T)))``: ``||delta||_2`` (L2 norm over all vertices) for a
        target in correspondence.
    rms_error : float or None
        ``||delta||_2 / sqrt(k)``, the root mean square vertex distance (None
        without correspondence).
    rkhs_norm : float
        ``||v_0||_H``.
    n_iter, n_evals : int
        Optimiser iterations and objective evaluations.
    n_flow_evaluations : int
        Passes through the flow: forward shootings, adjoint and tangent-linear passes.
    history : list of float
        Objective at the initial momenta and after every iteration.
    converged : bool
        Whether the settings' stopping rule was met.
    message : str
        Why the optimiser stopped.
    gradient_norm : float
        Largest entry of the final gradient in the optimiser's (preconditioned,
        normalised) variables.
    predicted_change : float
        Per-vertex RMS change of ``phi_1(T)`` predicted for a further Newton step
        from the final gradient (the ``"shape"`` rule's second test).
    settings_key : str
        :meth:`RegistrationSettings.key` of the settings used.
    trace : list of TraceRow
        Every iteration: flow passes so far, normalised objective, largest gradient
        entry, change of ``phi_1(T)`` and the predicted change
        (:class:`manifolds.numerics.solvers.TraceRow`).
    """

    momenta: np.ndarray
    control_points: np.ndarray
    deformed: np.ndarray
    residual: np.ndarray | None
    objective: float
    registration_error: float
    rms_error: float | None
    rkhs_norm: float
    n_iter: int
    n_evals: int
    n_flow_evaluations: int = 0
    history: list = field(default_factory=list)
    converged: bool = False
    message: str = ""
    gradient_norm: float = float("nan")
    predicted_change: float = float("nan")
    settings_key: str = ""
    trace: list = field(default_factory=list, repr=False)
