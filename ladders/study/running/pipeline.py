"""The paper's Section 3 study: symmetry errors over alpha^2, pole ladder vs fanning, area strain.

For every subject ``(S, S')`` (end-diastole, end-systole), the atlas ``T`` and
every ``alpha^2`` of a sweep, with and without residuals:

* the four errors of Section 3 (midpoint distance, centrality, involutivity,
  transvectivity), through the generic :func:`ladders.symmetry_errors`;
* the registration error and RKHS norm of ``T -> S`` and the inverse consistency;
* the pole-ladder transport of the deformation ``S -> S'`` to the atlas
  (Algorithm 1: ``T' = s_T o s_M (S')``), and the fanning scheme's transport;
* the local area strain between ``S`` and ``S'`` and between ``T`` and ``T'``,
  and the area strain error ASE.

Registrations are cached by the LDDMM space, so every registration the
errors and the ladders share is computed once.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from dataclasses import dataclass

import numpy as np

from manifolds.errors import ConvergenceWarning
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings, SVFLandmarks, group_pole_ladder
from manifolds.point_distance import point_distance
from manifolds.residual import ResidualAugmented

from ...fanning import fanning_transport
from ...symmetry_errors import symmetry_errors
from ..area_strain import area_strain, area_strain_error
from ..cohort import Subject

__all__ = ["StudyConfig", "DEFAULT_REGISTRATION", "run_subject", "VARIANTS", "ERROR_NAMES"]

VARIANTS = ("residual", "no_residual")
ERROR_NAMES = ("midpoint_distance", "centrality", "involutivity", "transvectivity")
#: Unit of the distances of the results, per ``StudyConfig.distance`` (meshes in mm).
UNITS = {
    "rms": "mm (per-vertex RMS)",
    "frobenius": "mm (Frobenius norm over vertices)",
    "mean": "mm (mean per-vertex distance)",
}


#: Registration settings of the default study (``docs/study.md``, "Settings chosen by
#: measurement"): 45 grid control points at ``sigma = 20`` mm, Euler, to the optimiser's
#: tolerance.
DEFAULT_REGISTRATION = RegistrationSettings(sigma=20.0, control_points="grid", max_iter=2000)


@dataclass(frozen=True)
class StudyConfig:
    """Parameters of the study (all of them enter the results' hash).

    Attributes
    ----------
    registration : RegistrationSettings
        Every setting of the registrations: kernel width (in the meshes' units, mm
        for the built-in cohort), control points (``"grid"``: spacing ``sigma`` over
        the template's bounding box, ``"finegrid"``: spacing ``sigma / 2``,
        ``"dense"``: the mesh vertices), their optimisation (eq. 3), integrator and
        steps, solver, stopping rule, tolerances, iteration limit, kernel backend.
    alpha2 : tuple of float
        Sweep of the regularisation ``alpha^2`` of eq. 3.
    fanning_steps : int
        Steps of the fanning scheme.
    deformation : str
        ``"lddmm"`` (:class:`~manifolds.lddmm.LDDMMLandmarks`) or ``"svf"``
        (:class:`~manifolds.lddmm.SVFLandmarks`). The fanning scheme integrates
        LDDMM geodesics; with ``"svf"`` its slot of the results holds the SVF
        pole ladder by conjugation, ``exp(-v/2) o exp(u) o exp(v/2)`` (``docs/svf.md``).
    distance : str
        Unit of the errors, the registration error and the inverse consistency:
        ``"rms"`` (per-vertex RMS distance, the paper's mm), ``"frobenius"`` or ``"mean"``.
    """

    registration: RegistrationSettings = DEFAULT_REGISTRATION
    alpha2: tuple = (0.01, 0.1, 1.0, 10.0, 33.0, 100.0, 1089.0)
    fanning_steps: int = 10
    deformation: str = "lddmm"
    distance: str = "rms"

    def __post_init__(self):
        if not isinstance(self.registration, RegistrationSettings):
            raise TypeError(
                "StudyConfig: registration: expected RegistrationSettings, got "
                f"{type(self.registration).__name__}"
            )
        object.__setattr__(self, "alpha2", tuple(float(a) for a in self.alpha2))

    @classmethod
    def build(cls, **fields) -> StudyConfig:
        """A configuration from study fields and registration settings given together.

        ``StudyConfig.build(alpha2=(1.0,), sigma=20.0, max_iter=15)`` sets ``alpha2``
        and overrides ``sigma`` and ``max_iter`` of :data:`DEFAULT_REGISTRATION`
        (or of ``registration=`` when given).
        """
        own = {f.name for f in dataclasses.fields(cls)}
        study = {k: v for k, v in fields.items() if k in own}
        changes = {k: v for k, v in fields.items() if k not in own}
        base = study.pop("registration", DEFAULT_REGISTRATION)
        return cls(registration=base.replace(**changes), **study)

    def as_dict(self) -> dict:
        """JSON-ready fields; the registration settings as their own dict and key."""
        return {
            "registration": self.registration.as_dict(),
            "registration_key": self.registration.key(),
            "alpha2": [float(a) for a in self.alpha2],
            "fanning_steps": self.fanning_steps,
            "deformation": self.deformation,
            "distance": self.distance,
        }


def make_space(config: StudyConfig, template: np.ndarray, alpha2: float):
    """The LDDMM or SVF space (``config.deformation``) of a study at one ``alpha^2``."""
    spaces = {"lddmm": LDDMMLandmarks, "svf": SVFLandmarks}
    if config.deformation not in spaces:
        raise ValueError(
            f"StudyConfig.deformation: expected 'lddmm' or 'svf', got {config.deformation!r}"
        )
    k, d = template.shape
    return spaces[config.deformation](
        n_landmarks=k,
        dim=d,
        alpha=float(np.sqrt(alpha2)),
        settings=config.registration,
    )


def _one_alpha(config, atlas, faces, subject, alpha2, las_subject, shapes=None) -> dict:
    space = make_space(config, atlas, alpha2)
    t, s, s2 = atlas, subject.ed, subject.es
    dist = point_distance(config.distance, space.point_shape)
    reg = space.register(t, s)
    out = {
        "registration_error": float(dist(reg.deformed, s)),
        "registration_rms": float(reg.rms_error),
        "rkhs_norm": float(reg.rkhs_norm),
        "converged": bool(reg.converged),
        "inverse_consistency": float(space.inverse_consistency(t, s, distance=dist)),
    }
    las = {"subject": las_subject}
    for variant in VARIANTS:
        sp = ResidualAugmented(space, use_residuals=variant == "residual")
        errs = symmetry_errors(sp, t, s, s2, distance=dist)
        t_prime = errs.points["pole_ladder"]  # T' = s_T(s_M(S')), Algorithm 1
        las[variant] = area_strain(t, t_prime, faces)
        if shapes is not None:
            shapes[variant] = {key: np.asarray(v) for key, v in errs.points.items()}
        out[variant] = {name: float(getattr(errs, name)) for name in ERROR_NAMES}
        out[variant]["ase"] = area_strain_error(las_subject, las[variant])
    if config.deformation == "svf":  # SVF pole ladder: conjugation of exp(u) by exp(v/2)
        t_fan = group_pole_ladder(space, t, space.log(t, s), space.log(s, s2), base=s)
    else:  # Fanning: transport Log_S(S') along the geodesic S -> T, then shoot the atlas.
        fan = fanning_transport(space, s, t, space.log(s, s2), n_steps=config.fanning_steps)
        t_fan = space.shoot(t, fan.momenta, control_points=fan.control_points)
    las["fanning"] = area_strain(t, t_fan, faces)
    if shapes is not None:
        shapes["fanning"] = {"transported": np.asarray(t_fan)}
    out["fanning"] = {"ase": area_strain_error(las_subject, las["fanning"])}
    out["las"] = {key: np.asarray(v).tolist() for key, v in las.items()}
    out["n_registrations"] = int(space.n_registrations)
    out["non_converged_registrations"] = int(space.n_unconverged)
    out["n_iterations"] = int(space.n_iterations)
    out["max_gradient_norm"] = float(space.max_gradient_norm)
    out["unit"] = UNITS[config.distance]
    return out


def run_subject(
    config: StudyConfig, atlas, faces, subject: Subject, keep_shapes: bool = False
) -> dict:
    """All results of one subject over the ``alpha^2`` sweep (a JSON-ready dict).

    Parameters
    ----------
    config : StudyConfig
    atlas : array, shape (k, 3)
        The atlas ``T``.
    faces : int array, shape (f, 3)
    subject : Subject
        A ``name`` and ``ed``, ``es`` vertex arrays ``(k, 3)`` in correspondence
        with ``atlas`` (e.g. a :class:`ladders.study.cohort.Subject`).
    keep_shapes : bool
        Also return the computed shapes, under the key ``"shapes"``:
        ``shapes[alpha2_key][variant]`` holds ``midpoint`` (``M``), ``reflected``
        (``s_M(S')``) and ``pole_ladder`` (``T'``) for ``variant`` in
        :data:`VARIANTS`, and ``shapes[alpha2_key]["fanning"]["transported"]``
        the fanning scheme's ``T'``; every array is ``(k, 3)``. These arrays are
        not JSON-serialisable: :func:`ladders.study.meshes.mesh_outputs.write_subject_meshes`
        writes them as mesh files and removes them from the result.
    """
    start = time.perf_counter()
    las_subject = area_strain(subject.ed, subject.es, faces)
    # Registrations stopped by the iteration limit are counted and reported in
    # the results and by the command line, rather than warned once per call.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        shapes = {str(float(a2)): {} for a2 in config.alpha2}
        results = {
            key: _one_alpha(
                config, atlas, faces, subject, float(key), las_subject,
                shapes[key] if keep_shapes else None,
            )
            for key in shapes
        }  # fmt: skip
    for w in caught:
        if not issubclass(w.category, ConvergenceWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    out = {
        "subject": subject.name,
        "alpha2": results,
        "non_converged_registrations": sum(
            r["non_converged_registrations"] for r in results.values()
        ),
        "seconds": time.perf_counter() - start,
    }
    if keep_shapes:
        out["shapes"] = shapes
    return out
