"""The registration settings of the default study, shared by the study and its deformation models."""

from __future__ import annotations

from manifolds.lddmm import RegistrationSettings

__all__ = ["DEFAULT_REGISTRATION"]

#: Registration settings of the default study (``docs/developer_notes.md``, "Settings chosen by
#: measurement"): a kernel of width ``sigma = 10`` mm on control points at the shapes'
#: vertices, a farthest-point sample of the atlas at a spacing of ``0.7 sigma`` (143
#: points on the built-in atlas) used on every shape
#: (:meth:`~manifolds.lddmm.RegistrationSettings.fix_control_point_indices`), 10 Euler
#: steps, L-BFGS-B stopped when the deformed template moves by less than 1e-4 mm
#: (per-vertex RMS) per iteration.
DEFAULT_REGISTRATION = RegistrationSettings(
    sigma=10.0,
    control_points="vertices",
    integrator="euler",
    stopping="shape",
    shape_tol=1e-4,
    max_iter=5000,
)
