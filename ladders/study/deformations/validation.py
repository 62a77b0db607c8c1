"""Checking a deformation model before a study runs on it.

* :func:`check_deformation_model`: the interface, in seconds, on the study's own atlas
  and settings; ``symladders study`` and :func:`ladders.study.run` call it before any
  registration. A model that breaks it is refused with one line naming the model and
  the property: the space's point shape, ``exp`` giving a point of that shape, ``log``
  inverting ``exp`` (at a small ``alpha^2``, where the registration is exact),
  :meth:`~.model.DeformationModel.register` matching its target, a finite inverse
  consistency.
* :func:`validate_deformation_model`: that, plus the contract every space of the
  library meets (:class:`manifolds.testing.ConnectionContract`, run on shapes near
  the template) and the pole ladder's convergence: with ``n`` rungs its error
  against a reference transport (the space's exact ``parallel_transport``, else the
  ladder with many rungs) decreases as ``n^-2``, or is at round-off (a symmetric space).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from manifolds.connection import Connection
from manifolds.point_distance import point_distance

from ...convergence import ConvergenceCurve, loglog_slope
from ...pole_ladder import pole_ladder
from ..default_registration import DEFAULT_REGISTRATION
from .model import DeformationModel, Registration
from .registry import DeformationModelError, deformation_model

__all__ = [
    "CHECK_ALPHA2",
    "ModelValidation",
    "check_deformation_model",
    "validate_deformation_model",
]

#: The ``alpha^2`` of the checks: small enough that a registration matches its target.
CHECK_ALPHA2 = 1e-6


def _who(model) -> str:
    return f"deformation model {getattr(model, 'name', '?')!r} ({type(model).__name__})"


def _fail(model, prop: str, what: str) -> DeformationModelError:
    return DeformationModelError(f"{_who(model)}: {prop}: {' '.join(str(what).split())}")


def _spread(template: np.ndarray) -> float:
    """RMS distance of the template's points to their centroid (the shapes' scale)."""
    centred = template - template.mean(axis=0)
    return float(np.sqrt((centred**2).sum(axis=-1).mean())) or 1.0


def _call(model, prop: str, f, *args):
    """``f(*args)``, any exception turned into a one-line refusal naming ``prop``."""
    try:
        return f(*args)
    except DeformationModelError:
        raise
    except Exception as exc:
        raise _fail(model, prop, f"raised {type(exc).__name__}: {exc}") from exc


def _point(model, prop: str, x, shape) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise _fail(
            model, prop, f"expected an array of shape {shape}, got {type(x).__name__}"
        ) from None
    if arr.shape != tuple(shape):
        raise _fail(model, prop, f"expected shape {tuple(shape)}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise _fail(model, prop, "not finite")
    return arr


def check_deformation_model(
    model,
    template,
    settings=DEFAULT_REGISTRATION,
    *,
    seed: int = 0,
    rtol: float = 0.05,
) -> DeformationModel:
    """Check that ``model`` keeps the interface the study relies on (seconds).

    Parameters
    ----------
    model : str or DeformationModel
        A registered name or a model.
    template : array, shape (k, d)
        The study's atlas.
    settings : manifolds.lddmm.RegistrationSettings
        The study's registration settings.
    seed : int
        Seed of the random tangent.
    rtol : float
        Largest error of ``Exp_T(Log_T(x))`` and of the registration's deformed template,
        relative to the displacement ``x - T`` (``x = Exp_T(v)``, ``v`` a random tangent
        moving the shape by about 2 % of its size).

    Returns
    -------
    DeformationModel

    Raises
    ------
    DeformationModelError
        One line naming the model and the failing property.
    """
    model = deformation_model(model)
    template = np.asarray(template, dtype=float)
    if not isinstance(model, DeformationModel):
        raise _fail(model, "interface", "not a DeformationModel")
    try:
        model.check_settings(settings)
    except ValueError as exc:
        raise _fail(model, "settings", exc) from None
    space = _call(model, "make_space", model.make_space, template, CHECK_ALPHA2, settings)
    if not isinstance(space, Connection):
        raise _fail(model, "make_space", f"expected a manifolds.Connection, got "
                    f"{type(space).__name__}")  # fmt: skip
    if tuple(space.point_shape) != template.shape:
        raise _fail(model, "point_shape", f"expected the template's shape {template.shape}, "
                    f"got {tuple(space.point_shape)}")  # fmt: skip
    rng = np.random.default_rng(seed)
    v = _call(
        model, "random_tangent", space.random_tangent, template, rng, 0.02 * _spread(template)
    )
    x = _point(model, "exp shape", _call(model, "exp", space.exp, template, v), template.shape)
    rms = point_distance("rms", template.shape)
    moved = float(rms(x, template))
    if moved == 0.0:
        raise _fail(model, "exp", "Exp_T(v) = T for a nonzero random tangent v")
    reg = _call(model, "register", model.register, space, template, x)
    if not isinstance(reg, Registration):
        raise _fail(model, "register", f"expected a Registration, got {type(reg).__name__}")
    deformed = _point(model, "register shape", reg.deformed, template.shape)
    if not (np.isfinite(reg.norm) and reg.norm >= 0 and np.isfinite(reg.rms_error)):
        raise _fail(model, "register", f"norm {reg.norm!r}, rms_error {reg.rms_error!r}: "
                    "expected finite numbers, the norm >= 0")  # fmt: skip
    if reg.converged:  # a registration stopped by its iteration limit says nothing here
        back = _call(model, "log", space.log, template, x)
        again = _point(model, "exp shape", _call(model, "exp", space.exp, template, back),
                       template.shape)  # fmt: skip
        error = float(rms(again, x)) / moved
        if error > rtol:
            raise _fail(
                model,
                "log inverts exp",
                f"Exp_T(Log_T(x)) is {error:.3g} of the "
                f"displacement from x (tolerance {rtol:g}, alpha^2 = {CHECK_ALPHA2:g})",
            )
        error = float(rms(deformed, x)) / moved
        if error > rtol:
            raise _fail(model, "register", f"the deformed template is {error:.3g} of the "
                        f"displacement from its target (tolerance {rtol:g})")  # fmt: skip
    ic = _call(model, "inverse_consistency", model.inverse_consistency, space, template, x, "rms")
    if not (np.isfinite(ic) and ic >= 0):
        raise _fail(model, "inverse_consistency", f"expected a finite number >= 0, got {ic!r}")
    residual = _call(model, "residual_space", model.residual_space, space, True)
    if not isinstance(residual, Connection):
        raise _fail(model, "residual_space", f"expected a manifolds.Connection, got "
                    f"{type(residual).__name__}")  # fmt: skip
    return model


@dataclass
class ModelValidation:
    """What :func:`validate_deformation_model` found.

    Attributes
    ----------
    model : DeformationModel
    checks : dict
        ``property -> "passed" | "skipped: why" | "failed: why"``.
    convergence : ConvergenceCurve or None
        The pole ladder's errors against the reference, relative to the reference's
        displacement of the template.
    reference : str
        ``"parallel transport"`` or ``"pole ladder, N rungs"``.
    seconds : float
    """

    model: DeformationModel
    checks: dict = field(default_factory=dict)
    convergence: ConvergenceCurve | None = None
    reference: str = ""
    seconds: float = 0.0

    @property
    def failures(self) -> dict:
        """The checks that failed, with why."""
        return {k: v for k, v in self.checks.items() if v.startswith("failed")}

    @property
    def ok(self) -> bool:
        return not self.failures

    def to_markdown(self) -> str:
        """The checks as a Markdown table, then the convergence curve."""
        lines = [f"{_who(self.model)}: {'passed' if self.ok else 'FAILED'} "
                 f"({self.seconds:.1f} s)", "", "| check | result |", "|---|---|"]  # fmt: skip
        lines += [f"| {k} | {v} |" for k, v in self.checks.items()]
        c = self.convergence
        if c is not None:
            lines += ["", f"Pole ladder against the {self.reference}: rungs "
                      f"{', '.join(f'{n:g}' for n in c.n_rungs)}, relative errors "
                      f"{', '.join(f'{e:.2e}' for e in c.errors)}"]  # fmt: skip
        return "\n".join(lines) + "\n"


def _contract(space, template, scale: float, tol: float, max_examples: int):
    """A :class:`~manifolds.testing.ConnectionContract` on shapes near ``template``, with
    absolute tolerances ``tol`` times the sizes the shapes and tangents have."""
    from manifolds.testing import ConnectionContract

    rng = np.random.default_rng(12345)
    unit = space.random_tangent(template, rng, scale)

    class Contract(ConnectionContract):
        tangent_scale = scale
        far_scale = 0.0

        def random_point(self, rng):
            return space.exp(template, space.random_tangent(template, rng, 2.0 * scale))

        def assert_points_close(self, x, y):
            np.testing.assert_allclose(x, y, rtol=0, atol=tol * scale)

        def assert_tangents_close(self, u, v):
            for a, b, ref in zip(self.tangent_arrays(u), self.tangent_arrays(v),
                                 self.tangent_arrays(unit), strict=True):  # fmt: skip
                size = float(np.max(np.abs(ref))) or 1.0
                np.testing.assert_allclose(a, b, rtol=0, atol=tol * size)

    Contract.space = space
    Contract.atol = tol * scale
    Contract.max_examples = max_examples
    return Contract()


def _ladder_convergence(space, template, scale, n_rungs, reference_rungs, seed):
    """Pole ladder errors against the exact transport or the ladder with many rungs.

    ``S`` is about 20 % of the template's size away from it and ``u`` half that: large
    enough that the ladder's error stands above the registrations' tolerance (with 5 %
    and 2 % the LDDMM ladder's error meets the 1e-4 mm stopping rule at four rungs).
    """
    rng = np.random.default_rng(seed)
    s = space.exp(template, space.random_tangent(template, rng, 10.0 * scale))
    u = space.random_tangent(s, rng, 4.0 * scale)
    try:
        exact = space.parallel_transport(s, template, u)
        reference = "parallel transport"
    except NotImplementedError:
        exact = pole_ladder(space, s, template, u, n_rungs=reference_rungs)
        reference = f"pole ladder, {reference_rungs} rungs"
    rms = point_distance("rms", template.shape)
    target = space.exp(template, exact)
    size = float(rms(target, template)) or 1.0
    errors = [float(rms(space.exp(template, pole_ladder(space, s, template, u, n_rungs=n)),
                        target)) / size for n in n_rungs]  # fmt: skip
    return ConvergenceCurve("pole ladder", np.asarray(n_rungs, dtype=float),
                            np.asarray(errors)), reference  # fmt: skip


def validate_deformation_model(
    model,
    template=None,
    settings=DEFAULT_REGISTRATION,
    *,
    tol: float = 1e-2,
    max_examples: int = 2,
    n_rungs=(1, 2, 4),
    reference_rungs: int = 16,
    exact_below: float = 1e-6,
    max_slope: float = -1.5,
    seed: int = 0,
    raise_on_failure: bool = True,
) -> ModelValidation:
    """Validate ``model`` (a registered name or a model): interface, contract, ladder convergence.

    Parameters
    ----------
    model : str or DeformationModel
    template : array, shape (k, 3), optional
        Default: the built-in synthetic atlas on a coarse grid (41 vertices, in mm).
    settings : manifolds.lddmm.RegistrationSettings
        Default: the study's :data:`~ladders.study.default_registration.DEFAULT_REGISTRATION`.
    tol : float
        Tolerance of the contract, relative to the size of the shapes' displacements
        (points) and of a random tangent's largest entry (tangents).
    max_examples : int
        Random configurations per property of the contract.
    n_rungs : sequence of int
        Rungs of the pole ladder whose errors are measured.
    reference_rungs : int
        Rungs of the reference ladder when the space has no exact ``parallel_transport``.
    exact_below : float
        Errors all below this (relative) mean an exact ladder (a symmetric space): passed.
    max_slope : float
        Otherwise the errors' log-log slope against the rungs must be at most this
        (second order: ``-2``).
    seed : int
    raise_on_failure : bool, default True
        Raise on the first failed check (:class:`DeformationModelError`, one line);
        otherwise return the report with every check.

    Returns
    -------
    ModelValidation

    Notes
    -----
    The contract needs pytest and hypothesis (the ``test`` extra).
    """
    start = time.perf_counter()
    model = deformation_model(model)
    if template is None:
        from ..cohort import make_synthetic_cohort

        template = make_synthetic_cohort(1, grid=(8, 5), seed=seed).atlas
    template = np.asarray(template, dtype=float)
    report = ModelValidation(model)
    try:
        check_deformation_model(model, template, settings, seed=seed)
        report.checks["interface"] = "passed"
    except DeformationModelError as exc:
        if raise_on_failure:
            raise
        report.checks["interface"] = f"failed: {exc}"
        report.seconds = time.perf_counter() - start
        return report
    space = model.make_space(template, CHECK_ALPHA2, settings)
    scale = 0.02 * _spread(template)
    from manifolds.testing import run_contract

    report.checks.update(run_contract(_contract(space, template, scale, tol, max_examples)))
    try:
        curve, report.reference = _ladder_convergence(space, template, scale, n_rungs,
                                                      reference_rungs, seed)  # fmt: skip
        report.convergence = curve
        if np.all(curve.errors < exact_below):
            report.checks["ladder convergence"] = "passed (exact: a symmetric space)"
        else:
            slope = loglog_slope(curve.n_rungs, np.maximum(curve.errors, 1e-300))
            verdict = "passed" if slope <= max_slope else "failed"
            report.checks["ladder convergence"] = (
                f"{verdict}: slope {slope:.2f} (at most {max_slope:g}) against the "
                f"{report.reference}"
            )
    except Exception as exc:
        report.checks["ladder convergence"] = f"failed: {type(exc).__name__}: {exc}"
    report.seconds = time.perf_counter() - start
    if raise_on_failure and report.failures:
        prop, why = next(iter(report.failures.items()))
        raise _fail(model, prop, why.removeprefix("failed: "))
    return report
