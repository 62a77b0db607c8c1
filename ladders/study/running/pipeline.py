"""The paper's Section 3 study: symmetry errors over alpha^2, pole ladder vs fanning, area strain.

For every subject ``(S, S')`` (end-diastole, end-systole), the atlas ``T`` and
every ``alpha^2`` of a sweep, with and without residuals:

* the four errors of Section 3 (midpoint distance, centrality, involutivity,
  transvectivity), through the generic :func:`ladders.symmetry_errors`;
* the registration error and RKHS norm of ``T -> S`` and the inverse consistency;
* the pole-ladder transport of the deformation ``S -> S'`` to the atlas
  (Algorithm 1: ``T' = s_T o s_M (S')``), and the model's own transport where it
  has one (the fanning scheme for LDDMM, the SVF pole ladder by conjugation for
  SVF; a model without one has it recorded as skipped, with the reason);
* the local area strain between ``S`` and ``S'`` and between ``T`` and ``T'``,
  and the area strain error ASE.

The deformation model is any registered :class:`~ladders.study.deformations.DeformationModel`
(``StudyConfig.deformation``); the study asks it for nothing else. The kernel models
cache their registrations, so every registration the errors and the ladders share is
computed once. :func:`compute_pair` is the one computation of a (subject, ``alpha^2``)
pair; the results are the typed :class:`~ladders.study.running.results.PairResult`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
import warnings
from dataclasses import dataclass

import numpy as np

from manifolds.errors import ConvergenceWarning
from manifolds.lddmm import RegistrationSettings
from manifolds.point_distance import point_distance

from ...symmetry_errors import symmetry_errors
from ..area_strain import area_strain, area_strain_error
from ..cohort import Subject
from ..default_registration import DEFAULT_REGISTRATION
from ..deformations import DeformationModel, DeformationModelError, deformation_model
from ..meshes.mesh_outputs import MESH_OUTPUT_FORMATS, TransportShapes, write_subject_meshes
from ..volume import enclosed_volume
from .results import (
    ERROR_NAMES,
    POLE_LADDER,
    VARIANTS,
    PairResult,
    RegistrationCounts,
    RegistrationSummary,
    SkippedTransport,
    SubjectResults,
    TransportResult,
    VariantErrors,
)

__all__ = [
    "StudyConfig",
    "DEFAULT_REGISTRATION",
    "UNITS",
    "make_space",
    "compute_pair",
    "run_subject",
    "VARIANTS",
    "ERROR_NAMES",
]
#: Unit of the distances of the results, per ``StudyConfig.distance`` (meshes in mm).
UNITS = {
    "rms": "mm (per-vertex RMS)",
    "frobenius": "mm (Frobenius norm over vertices)",
    "mean": "mm (mean per-vertex distance)",
}


@dataclass(frozen=True)
class StudyConfig:
    """Parameters of the study (all of them enter the results' hash).

    Attributes
    ----------
    registration : RegistrationSettings
        Every setting of the registrations: kernel width (in the meshes' units, mm
        for the built-in cohort), control points (``"grid"``: spacing ``sigma`` over
        the template's bounding box, ``"finegrid"``: spacing ``sigma / 2``,
        ``"dense"``: the mesh vertices, :func:`manifolds.lddmm.control_points.is_dense`),
        their optimisation (eq. 3), integrator and
        steps, solver, stopping rule, tolerances, iteration limit, kernel backend.
    alpha2 : tuple of float
        Sweep of the regularisation ``alpha^2`` of eq. 3.
    fanning_steps : int
        Steps of the fanning scheme (with the space's integrator; equal to the
        registration's ``n_steps``, the fanning follows the space's own discrete geodesic).
    deformation : str or DeformationModel
        The name of a registered deformation model
        (:func:`~ladders.study.deformations.deformation_names`: ``"lddmm"``,
        :class:`~manifolds.lddmm.LDDMMLandmarks`; ``"svf"``,
        :class:`~manifolds.lddmm.SVFLandmarks`; any a user registers), or a model
        itself; the field keeps its name and :attr:`model` the model. The third
        transport of the study is the model's own: the fanning scheme
        (``"fanning"``) with LDDMM, which has a flow of momenta, the SVF pole ladder
        by conjugation (``"svf_conjugation"``, ``exp(-v/2) o exp(u) o exp(v/2)``,
        ``docs/svf.md``) with SVF, none (recorded as skipped) for a model without one.
    distance : str
        Unit of the errors, the registration error and the inverse consistency:
        ``"rms"`` (per-vertex RMS distance, the paper's mm), ``"frobenius"`` or ``"mean"``.
    warm_starts : bool
        Start ``Log_M(s_M(S'))`` (involutivity) from its symmetric counterpart
        ``-Log_M(S')`` (:func:`ladders.symmetry_errors`, ``warm_start``) instead of
        the linearised start.
    model : DeformationModel
        The model of ``deformation`` (set from it, not compared; pickled with the
        configuration, so the processes of a parallel study run the same model).
    """

    registration: RegistrationSettings = DEFAULT_REGISTRATION
    alpha2: tuple = (0.01, 0.1, 1.0, 10.0, 33.0, 100.0, 1089.0)
    fanning_steps: int = 10
    deformation: str = "lddmm"
    distance: str = "rms"
    warm_starts: bool = False
    model: DeformationModel = dataclasses.field(init=False, compare=False, repr=False)

    def __post_init__(self):
        """Every field checked here, so that a bad one stops a study before any registration."""
        if not isinstance(self.registration, RegistrationSettings):
            raise TypeError(
                "StudyConfig: registration: expected RegistrationSettings, got "
                f"{type(self.registration).__name__}"
            )
        try:
            alpha2 = tuple(self.alpha2)
        except TypeError:
            raise ValueError(
                f"StudyConfig.alpha2: expected a sequence of numbers > 0, got {self.alpha2!r}"
            ) from None
        if not alpha2:
            raise ValueError("StudyConfig.alpha2: expected at least one value, got none")
        alpha2 = tuple(_check_alpha2(a, "StudyConfig.alpha2") for a in alpha2)
        if len(set(alpha2)) != len(alpha2):
            raise ValueError(f"StudyConfig.alpha2: values repeated in {list(alpha2)}")
        object.__setattr__(self, "alpha2", alpha2)
        try:
            model = deformation_model(self.deformation)
        except DeformationModelError as exc:
            raise ValueError(f"StudyConfig.{exc}") from None
        object.__setattr__(self, "deformation", model.name)
        object.__setattr__(self, "model", model)
        if self.distance not in UNITS:
            raise ValueError(
                f"StudyConfig.distance: expected one of {sorted(UNITS)}, got {self.distance!r}"
            )
        steps = self.fanning_steps
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
            raise ValueError(f"StudyConfig.fanning_steps: expected an int >= 1, got {steps!r}")
        if not isinstance(self.warm_starts, (bool, np.bool_)):
            raise ValueError(f"StudyConfig.warm_starts: expected a bool, got {self.warm_starts!r}")

    @classmethod
    def build(cls, **fields) -> StudyConfig:
        """A configuration from study fields and registration settings given together.

        ``StudyConfig.build(alpha2=(1.0,), sigma=20.0, max_iter=15)`` sets ``alpha2``
        and overrides ``sigma`` and ``max_iter`` of :data:`DEFAULT_REGISTRATION`
        (or of ``registration=`` when given).
        """
        own = {f.name for f in dataclasses.fields(cls) if f.init}
        study = {k: v for k, v in fields.items() if k in own}
        changes = {k: v for k, v in fields.items() if k not in own}
        base = study.pop("registration", DEFAULT_REGISTRATION)
        return cls(registration=base.replace(**changes), **study)

    def as_dict(self) -> dict:
        """JSON-ready fields; the registration settings as their own dict and key; the
        model's own settings (:meth:`DeformationModel.settings`) when it has any."""
        out = {
            "registration": self.registration.as_dict(),
            "registration_key": self.registration.key(),
            "alpha2": [float(a) for a in self.alpha2],
            "fanning_steps": self.fanning_steps,
            "deformation": self.deformation,
            "distance": self.distance,
            "warm_starts": self.warm_starts,
        }
        model_settings = self.model.settings()
        if model_settings:  # absent for the built-in models: their results' keys stay
            out["deformation_settings"] = model_settings
        return out


def make_space(config: StudyConfig, template: np.ndarray, alpha2: float):
    """The space of ``config.model`` on ``template`` (the atlas) at one ``alpha^2``
    (:meth:`~ladders.study.deformations.DeformationModel.make_space`)."""
    return config.model.make_space(np.asarray(template, dtype=float), alpha2, config.registration)


def _check_alpha2(alpha2, name: str = "alpha2") -> float:
    number = isinstance(alpha2, (int, float, np.integer, np.floating))
    value = float(alpha2) if number else float("nan")
    if isinstance(alpha2, bool) or not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name}: expected a finite number > 0, got {alpha2!r}")
    return value


@contextlib.contextmanager
def _counted_convergence_warnings():
    """Silence :class:`ConvergenceWarning` (the spaces count stopped registrations)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        yield
    for w in caught:
        if not issubclass(w.category, ConvergenceWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def _own_transport(config, space, t, s, s2):
    """The model's own transport: ``(shapes, tangent)``, or ``(SkippedTransport, None)``
    when the model has none (:class:`NotImplementedError`, its message the reason)."""
    model = config.model
    try:
        out = model.transport(space, t, s, s2, config.fanning_steps)
    except NotImplementedError as exc:
        return SkippedTransport(model.transport_method, str(exc)), None
    return TransportShapes(model.transport_method, np.asarray(out.transported, dtype=float)), (
        out.tangent
    )


def _pole_ladder_tangent(config, space, sp, t, reflected):
    """Coordinates and residual of the pole ladder's tangent ``-Log_T(T'')`` (cached registration);
    a residual space whose tangents are not :class:`~manifolds.ResidualTangent` has none."""
    tangent = -sp.log(t, reflected)
    coordinates = config.model.tangent_coordinates(space, t, getattr(tangent, "tangent", tangent))
    residual = getattr(tangent, "residual", None) if getattr(sp, "use_residuals", False) else None
    return coordinates, residual


def _transports(config, space, dist, atlas, faces, subject, las_subject):
    """Symmetry errors of both variants and the transports, with their shapes."""
    t, s, s2 = atlas, subject.ed, subject.es
    errors, transports, shapes, tangents, skipped = [], [], [], [], []
    for variant in VARIANTS:
        sp = config.model.residual_space(space, use_residuals=variant == "residual")
        errs = symmetry_errors(sp, t, s, s2, distance=dist, warm_start=config.warm_starts)
        errors.append(VariantErrors(variant, *(float(getattr(errs, n)) for n in ERROR_NAMES)))
        points = errs.points  # T' = s_T(s_M(S')), Algorithm 1
        shapes.append(
            TransportShapes(
                POLE_LADDER[variant],
                points["pole_ladder"],
                points["midpoint"],
                points["reflected"],
            )
        )
        tangents.append(_pole_ladder_tangent(config, space, sp, t, points["reflected"]))
    own, tangent = _own_transport(config, space, t, s, s2)
    if isinstance(own, SkippedTransport):
        skipped.append(own)
    else:
        shapes.append(own)
        tangents.append((tangent, None))
    for shape, (momenta, residual) in zip(shapes, tangents):
        las = area_strain(t, shape.transported, faces)
        ase = area_strain_error(las_subject, las)
        transports.append(
            TransportResult(
                shape.method,
                ase,
                las,
                displacement=np.ravel(shape.transported - t),
                momenta=() if momenta is None else np.ravel(momenta),
                residual=() if residual is None else np.ravel(residual),
            )
        )
    return errors, transports, shapes, skipped


def compute_pair(
    config: StudyConfig,
    atlas,
    faces,
    subject: Subject,
    alpha2: float,
    meshes=None,
    mesh_format: str = ".vtu",
) -> PairResult:
    """The results of one subject at one ``alpha^2``: the one computation of a study pair.

    Everything else (a whole subject, a cohort, in parallel, resumed) calls it.

    Parameters
    ----------
    config : StudyConfig
        The registration settings (``config.registration``) and the study's own.
    atlas : array, shape (k, 3)
        The atlas ``T``.
    faces : int array, shape (f, 3)
    subject : Subject
        A ``name`` and ``ed``, ``es`` vertex arrays ``(k, 3)`` in correspondence
        with ``atlas``.
    alpha2 : float
        The regularisation ``alpha^2`` of eq. 3 (> 0).
    meshes : path, optional
        A folder: the pair's shapes and strain maps are written there
        (:func:`ladders.study.meshes.write_subject_meshes`).
    mesh_format : {".vtu", ".vtk"}
        Format of those files.

    Returns
    -------
    PairResult

    Notes
    -----
    Registrations stopped by the iteration limit are counted by the space
    (``result.counts.non_converged``) rather than warned once per call.
    """
    start = time.perf_counter()
    alpha2 = _check_alpha2(alpha2)
    if meshes is not None and mesh_format not in MESH_OUTPUT_FORMATS:
        raise ValueError(f"mesh_format: expected one of {MESH_OUTPUT_FORMATS}, got {mesh_format!r}")
    las_subject = area_strain(subject.ed, subject.es, faces)
    with _counted_convergence_warnings():
        model = config.model
        space = make_space(config, atlas, alpha2)
        dist = point_distance(config.distance, space.point_shape)
        reg = model.register(space, atlas, subject.ed)
        registration = RegistrationSummary(
            error=float(dist(reg.deformed, subject.ed)),
            rms=float(reg.rms_error),
            rkhs_norm=float(reg.norm),
            converged=bool(reg.converged),
            inverse_consistency=float(
                model.inverse_consistency(space, atlas, subject.ed, distance=dist)
            ),
        )
        errors, transports, shapes, skipped = _transports(
            config, space, dist, atlas, faces, subject, las_subject
        )
    result = PairResult(
        subject=subject.name,
        alpha2=alpha2,
        settings_key=config.registration.key(),
        deformation=config.deformation,
        unit=UNITS[config.distance],
        registration=registration,
        errors=tuple(errors),
        transports=tuple(transports),
        las_subject=las_subject,
        counts=RegistrationCounts.of_counters(model.counts(space)),
        seconds=0.0,
        kernel_backend=config.registration.resolved_backend(),
        displacement_subject=np.ravel(subject.es - subject.ed),
        volume_ratio_subject=enclosed_volume(subject.es, faces)
        / enclosed_volume(subject.ed, faces),
        skipped_transports=tuple(skipped),
    )
    if meshes is not None:
        write_subject_meshes(meshes, subject, atlas, faces, result, shapes, ext=mesh_format)
    return dataclasses.replace(result, seconds=time.perf_counter() - start)


def run_subject(config: StudyConfig, atlas, faces, subject: Subject) -> SubjectResults:
    """The results of one subject over the sweep ``config.alpha2`` (:func:`compute_pair` each).

    An exception of one pair propagates; :func:`ladders.study.running.runner.run_study`
    records it and goes on instead.
    """
    pairs = [compute_pair(config, atlas, faces, subject, a) for a in config.alpha2]
    return SubjectResults(subject.name, tuple(pairs))
