"""A synthetic cohort in several groups, with covariates acting on the anatomy and the motion.

:func:`make_covariate_cohort` draws the subjects of
:func:`~ladders.study.cohort.synthetic_lv.make_synthetic_cohort`, splits them into any
number of groups, each with its own planted
:class:`~ladders.study.cohort.planted_effect.MotionAbnormality` and/or
:class:`AnatomyShift`, draws per subject an age, a sex and a body size
(:class:`Covariates`, which states the model) and rebuilds both shapes from the changed
parameters. :func:`write_covariate_cohort` writes the meshes, ``groups.csv``,
``design.csv`` and the truth ``planted_region.json`` (format in ``docs/cohort.md``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from manifolds.validation import check_rng

from ..cohort.cohort import Cohort, Subject
from ..cohort.planted_effect import MotionAbnormality, planted_modulation, planted_region
from ..cohort.segmentation_noise import smooth_normal_noise
from ..cohort.synthetic_lv import (
    SyntheticLVModel,
    grid_shape,
    lv_grid,
    lv_shapes,
    make_synthetic_cohort,
)
from ..errors import CohortError
from .cohort_outcome import OUTCOME_CENSORING, cohort_outcome
from .two_groups import (
    _NOISE_KEY,
    CONTROLS,
    DEFAULT_ABNORMALITY,
    PATIENTS,
    _child,
    _seed,
    write_two_group_cohort,
)

__all__ = [
    "AnatomyShift", "Covariates", "CohortGroup", "CovariateCohort", "DESIGN_FILE",
    "make_covariate_cohort", "write_covariate_cohort",
]  # fmt: skip

#: The design table written next to the meshes (columns subject, group, age, sex, body_size).
DESIGN_FILE = "design.csv"
_COVARIATES_KEY = 4_000_000  # spawn keys of the covariate draws (one per group)
_OUTCOME_KEY = 5_000_000  # spawn key of the outcome's draw
_CLIP = 3.0  # the standard normal draws are clipped to +-3


def _number(value, name: str, low: float, high: float) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = float("nan")
    if isinstance(value, bool) or not low <= x <= high:
        raise CohortError(f"{name}: expected a number in [{low:g}, {high:g}], got {value!r}")
    return x


def _check_fields(obj, bounds: dict) -> None:
    """Each field of the frozen dataclass ``obj`` as a float within its bounds."""
    for name, (low, high) in bounds.items():
        value = _number(getattr(obj, name), f"{type(obj).__name__}.{name}", low, high)
        object.__setattr__(obj, name, value)


@dataclass(frozen=True)
class AnatomyShift:
    """A change of the end-diastolic anatomy of a group, its motion parameters unchanged.

    The motion parameters (fractions and angles) are applied to the changed anatomy, so
    the motion is the same relative to it: ``scale`` and ``sphericity`` are linear maps
    ``diag(alpha, alpha, beta)`` of both shapes, which leave each subject's ES/ED volume
    ratio exactly unchanged; ``bulge`` changes it slightly (the cavity's weight per level).

    Attributes
    ----------
    scale : float, default 1.0
        Factor of every length (base radius ``a`` and long axis ``c``), in [0.5, 2].
    sphericity : float, default 1.0
        Extra factor of the base radius ``a`` alone (> 1: rounder), in [0.5, 2].
    bulge : float, default 0.0
        Added to the mid-ventricular bulge ``b`` (> 0: wider mid-ventricle), in [-0.2, 0.2].
    """

    scale: float = 1.0
    sphericity: float = 1.0
    bulge: float = 0.0

    def __post_init__(self):
        _check_fields(self, {"scale": (0.5, 2), "sphericity": (0.5, 2), "bulge": (-0.2, 0.2)})

    def apply(self, params):
        """``params`` (a ``SubjectParameters``) with the anatomy changed."""
        return replace(
            params,
            radius=params.radius * self.scale * self.sphericity,
            long_axis=params.long_axis * self.scale,
            bulge=params.bulge + self.bulge,
        )


@dataclass(frozen=True)
class Covariates:
    """Age, sex and body size: their distribution per group and their effect on the shapes.

    Per subject ``z_age, z_size ~ N(0, 1)`` clipped to +-3, and with ``d = imbalance``
    for every group but the first (0 for the first)::

        age       = age_mean + age_sd (z_age + d shift)          (years, rounded to 0.1)
        body_size = 1 + body_size_sd (z_size + d shift)          (rounded to 0.001)
        sex       = "M" for round((male_fraction + d sex_shift) n) of the n subjects

    Effects: ``r0`` and ``l`` are multiplied by
    ``k = (1 - age_effect (age - age_mean) / age_sd) (1 - sex_effect [sex == "M"])`` and
    ``a``, ``c`` by ``body_size``.

    Attributes
    ----------
    age_mean, age_sd : float
        The reference group's age distribution, in years (defaults 60 and 10).
    age_effect : float, default 0.1
        Relative reduction of the contraction per standard deviation of age, in [0, 0.15].
    body_size_sd : float, default 0.08
        Standard deviation of the body size (a length factor, mean 1), in [0, 0.15].
    male_fraction : float, default 0.5
    sex_effect : float, default 0.0
        Relative reduction of the males' contraction, in [-0.2, 0.2] (0: no effect).
    imbalance : float, default 0.0
        How much the other groups' covariates differ from the first group's, in [0, 1].
    shift : float, default 2.0
        The age and body-size shift at ``imbalance = 1``, in standard deviations.
    sex_shift : float, default 0.25
        The change of the fraction of males at ``imbalance = 1``.
    """

    age_mean: float = 60.0
    age_sd: float = 10.0
    age_effect: float = 0.1
    body_size_sd: float = 0.08
    male_fraction: float = 0.5
    sex_effect: float = 0.0
    imbalance: float = 0.0
    shift: float = 2.0
    sex_shift: float = 0.25

    def __post_init__(self):
        _check_fields(self, {
            "age_mean": (0, 150), "age_sd": (0.1, 50), "age_effect": (0, 0.15),
            "body_size_sd": (0, 0.15), "male_fraction": (0, 1), "sex_effect": (-0.2, 0.2),
            "imbalance": (0, 1), "shift": (-2, 2), "sex_shift": (-1, 1),
        })  # fmt: skip
        if not 0 <= self.male_fraction + self.imbalance * self.sex_shift <= 1:
            raise CohortError(
                f"Covariates.sex_shift: male_fraction + imbalance * sex_shift must lie in "
                f"[0, 1], got {self.male_fraction + self.imbalance * self.sex_shift:g}"
            )

    def group_means(self, shifted: bool) -> dict:
        """Expected age and body size and the fraction of males of a group."""
        d = self.imbalance if shifted else 0.0
        return {
            "age": self.age_mean + d * self.shift * self.age_sd,
            "body_size": 1.0 + d * self.shift * self.body_size_sd,
            "male_fraction": self.male_fraction + d * self.sex_shift,
        }

    def draw(self, n: int, shifted: bool, rng: np.random.Generator) -> dict:
        """The covariates of ``n`` subjects of one group (``shifted``: not the first).

        Returns
        -------
        dict
            ``age`` and ``body_size``, float arrays of shape ``(n,)``, and ``sex``, a
            list of ``"F"``/``"M"``.
        """
        rng = check_rng(rng)
        d = self.imbalance * self.shift if shifted else 0.0
        z = np.clip(rng.standard_normal((2, n)), -_CLIP, _CLIP) + d
        age = np.round(self.age_mean + self.age_sd * z[0], 1)
        size = np.round(1.0 + self.body_size_sd * z[1], 3)
        n_male = int(round(self.group_means(shifted)["male_fraction"] * n))
        sex = np.where(rng.permutation(n) < n_male, "M", "F").tolist()
        return {"age": age, "body_size": size, "sex": sex}

    def contraction_factor(self, age, sex) -> np.ndarray:
        """The factor ``k`` of ``r0`` and ``l`` (shape of ``age``; ``sex`` alike)."""
        male = np.asarray(sex) == "M"
        z = (np.asarray(age, dtype=float) - self.age_mean) / self.age_sd
        return (1.0 - self.age_effect * z) * (1.0 - self.sex_effect * male)

    def effects(self) -> dict:
        """JSON-ready truth: each covariate's model and coefficients, and the imbalance."""
        motion = "radial_contraction and longitudinal_shortening"
        age = "1 - age_effect * (age - age_mean) / age_sd"
        return {
            "model": asdict(self),
            "age": {"acts_on": motion, "factor": age,
                    "factor_per_year": -self.age_effect / self.age_sd},
            "sex": {"acts_on": motion, "factor": "1 - sex_effect if sex == 'M' else 1",
                    "male_factor": 1.0 - self.sex_effect},
            "body_size": {"acts_on": "every length of both shapes (radius and long_axis)",
                          "length_exponent": 1, "volume_exponent": 3},
            "imbalance": self.imbalance,
            "reference_group_means": self.group_means(False),
            "other_group_means": self.group_means(True),
        }  # fmt: skip


_EFFECTS = {"abnormality": MotionAbnormality, "anatomy": AnatomyShift}


@dataclass(frozen=True)
class CohortGroup:
    """One group: its name, planted motion abnormality and anatomy shift (both optional)."""

    name: str
    abnormality: MotionAbnormality | None = None
    anatomy: AnatomyShift | None = None

    @classmethod
    def parse(cls, spec) -> CohortGroup:
        """A group from a ``CohortGroup`` or ``(name, effect, ...)``; effects in any order."""
        if isinstance(spec, cls):
            return spec
        if not isinstance(spec, tuple | list) or not spec or not isinstance(spec[0], str):
            raise CohortError(f"groups: expected (name, effect, ...) tuples, got {spec!r}")
        effects = [e for e in spec[1:] if e is not None]
        found = {k: [e for e in effects if isinstance(e, t)] for k, t in _EFFECTS.items()}
        if sum(map(len, found.values())) < len(effects) or max(map(len, found.values())) > 1:
            raise CohortError(
                f"groups: group {spec[0]!r}: expected at most one MotionAbnormality and one "
                f"AnatomyShift, got {spec[1:]!r}"
            )
        return cls(spec[0], **{k: e[0] if e else None for k, e in found.items()})

    def as_dict(self) -> dict:
        """JSON-ready fields."""
        return {
            "abnormality": None if self.abnormality is None else self.abnormality.as_dict(),
            "anatomy": None if self.anatomy is None else asdict(self.anatomy),
        }


@dataclass
class CovariateCohort:
    """A cohort in several groups with covariates, and the truth of every effect.

    Attributes
    ----------
    cohort : Cohort
        In vertex correspondence with the atlas (what a study runs on).
    groups : dict
        ``{subject: group name}`` in cohort order.
    covariates : dict
        ``{subject: {"age": float, "body_size": float, "sex": "F" or "M"}}``.
    regions : dict
        ``{group name: PlantedRegion or None}``, in the order of the groups.
    specs : tuple of CohortGroup
    model : Covariates
    noise : float
        RMS of the segmentation noise, in mm.
    seed : int
    outcome : dict or None
        ``{subject: {"time": float, "event": 0 or 1}}``, a survival outcome simulated
        from the regional motion (:func:`~.cohort_outcome.cohort_outcome`), or None.
    outcome_effect : float or None
        Its log hazard ratio per standard deviation of the regional motion.
    """

    cohort: Cohort
    groups: dict
    covariates: dict
    regions: dict
    specs: tuple
    model: Covariates
    noise: float = 0.0
    seed: int = 0
    outcome: dict | None = None
    outcome_effect: float | None = None

    @property
    def effects(self) -> dict:
        """The covariates' true effects (:meth:`Covariates.effects`)."""
        return self.model.effects()

    def design_table(self) -> dict:
        """``{column: list}``: subject, group, age, sex, body_size (and time, event with an
        outcome) in cohort order."""
        names = self.cohort.names
        table = {"subject": names, "group": [self.groups[s] for s in names]}
        for key in ("age", "sex", "body_size"):
            table[key] = [self.covariates[s][key] for s in names]
        if self.outcome is not None:
            for key in ("time", "event"):
                table[key] = [self.outcome[s][key] for s in names]
        return table

    def description(self) -> dict:
        """JSON-ready truth (the folder's ``planted_region.json``, see ``docs/cohort.md``)."""
        first = next((g for g, r in self.regions.items() if r is not None), None)
        groups = {
            spec.name: {
                **spec.as_dict(),
                "n_subjects": sum(g == spec.name for g in self.groups.values()),
                "region": None if self.regions[spec.name] is None
                else self.regions[spec.name].as_dict(),
            }
            for spec in self.specs
        }  # fmt: skip
        return {
            "seed": self.seed,
            "n_subjects": len(self.cohort),
            "segmentation_noise_mm": self.noise,
            "region_group": first,
            "region": None if first is None else self.regions[first].as_dict(),
            "groups": groups,
            "covariates": self.effects,
            "outcome": None
            if self.outcome is None
            else {
                "columns": ["time", "event"],
                "log_hazard_ratio_per_sd": self.outcome_effect,
                "of": "the normal motion ED -> ES averaged over the planted region (every "
                "vertex without one), a weaker inward motion a higher hazard",
                "censoring": OUTCOME_CENSORING,
            },
        }


def _specs(groups, n_per_group) -> tuple[tuple, list[int]]:
    specs = tuple(CohortGroup.parse(g) for g in groups)
    if not specs:
        raise CohortError("groups: expected at least one group")
    names = [s.name for s in specs]
    for name in names:
        if not isinstance(name, str) or not name.strip() or name != name.strip() or "," in name:
            raise CohortError(f"groups: group names must be non-empty without commas: {name!r}")
        if names.count(name) > 1:
            raise CohortError(f"groups: duplicate group name {name!r}")
    sizes = [n_per_group] * len(specs) if np.ndim(n_per_group) == 0 else list(n_per_group)
    if len(sizes) != len(specs):
        raise CohortError(f"n_per_group: {len(sizes)} sizes for {len(specs)} groups")
    for n in sizes:
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 3:
            raise CohortError(f"n_per_group: expected at least 3 subjects per group, got {n!r}")
    return specs, [int(n) for n in sizes]


def make_covariate_cohort(
    n_per_group=20,
    groups=((CONTROLS, None), (PATIENTS, DEFAULT_ABNORMALITY)),
    covariates: Covariates | None = None,
    seed: int = 0,
    n_vertices: int = 1009,
    noise: float = 0.0,
    noise_length: float = 10.0,
    model: SyntheticLVModel | None = None,
    outcome_effect: float | None = None,
) -> CovariateCohort:
    """The synthetic cohort in several groups, with their planted effects and covariates.

    Parameters
    ----------
    n_per_group : int or sequence of int, default 20
        Subjects per group (at least 3), one number for all groups or one per group.
        The groups take consecutive subjects, in the order of ``groups``.
    groups : sequence
        ``(name, effect, ...)`` tuples or :class:`CohortGroup`; an effect is None, a
        :class:`MotionAbnormality` and/or an :class:`AnatomyShift`. The first group is
        the reference of the covariate imbalance. Names are unique.
    covariates : Covariates, optional
        Default ``Covariates()`` (age effect 0.1 per SD, no sex effect, no imbalance).
    seed : int, default 0
        Subject ``i``'s own parameters are those of ``make_synthetic_cohort(seed=seed)``;
        group ``g``'s covariates come from ``SeedSequence(seed, spawn_key=(4000000 + g,))``.
    n_vertices : int, default 1009
    noise, noise_length : float
        Segmentation noise RMS and correlation length, in mm (as in
        :func:`~ladders.study.population.make_two_group_cohort`).
    model : SyntheticLVModel, optional
    outcome_effect : float, optional
        Also a survival outcome (:func:`~.cohort_outcome.cohort_outcome`): the log hazard
        ratio per standard deviation of each subject's normal motion ED -> ES over the
        first planted region (every vertex without one); drawn from
        ``SeedSequence(seed, spawn_key=(5000000,))``.

    Returns
    -------
    CovariateCohort
    """
    seed = _seed(seed)
    specs, sizes = _specs(groups, n_per_group)
    covariates = Covariates() if covariates is None else covariates
    if not isinstance(covariates, Covariates):
        raise CohortError(f"covariates: expected a Covariates, got {type(covariates).__name__}")
    noise = _number(noise, "noise", 0.0, np.inf)
    model = model or SyntheticLVModel()
    base = make_synthetic_cohort(sum(sizes), n_vertices=n_vertices, seed=seed, model=model)
    theta, phi, _ = lv_grid(*grid_shape(n_vertices), model)
    subjects, membership, table, regions = [], {}, {}, {}
    start = 0
    for g, (spec, n) in enumerate(zip(specs, sizes)):
        drawn = covariates.draw(n, g > 0, _child(seed, _COVARIATES_KEY + g))
        k = covariates.contraction_factor(drawn["age"], drawn["sex"])
        modulation = None
        regions[spec.name] = None
        if spec.abnormality is not None:
            modulation = planted_modulation(spec.abnormality, theta, phi)
            regions[spec.name] = planted_region(spec.abnormality, theta, phi)
        for j, s in enumerate(base.subjects[start : start + n]):
            p = s.parameters if spec.anatomy is None else spec.anatomy.apply(s.parameters)
            size = float(drawn["body_size"][j])
            p = replace(
                p, radius=p.radius * size, long_axis=p.long_axis * size,
                radial_contraction=p.radial_contraction * float(k[j]),
                longitudinal_shortening=p.longitudinal_shortening * float(k[j]),
            )  # fmt: skip
            ed, es = lv_shapes(p, theta, phi, modulation)
            if noise > 0:
                rng = _child(seed, _NOISE_KEY + start + j)
                ed = smooth_normal_noise(ed, base.faces, noise, rng, noise_length)
                es = smooth_normal_noise(es, base.faces, noise, rng, noise_length)
            subjects.append(Subject(s.name, ed, es, p))
            membership[s.name] = spec.name
            table[s.name] = {
                "age": float(drawn["age"][j]),
                "body_size": size,
                "sex": drawn["sex"][j],
            }
        start += n
    source = (
        f"make_covariate_cohort(n_per_group={sizes}, groups={[s.name for s in specs]}, "
        f"imbalance={covariates.imbalance:g}, noise={noise:g} mm, seed={seed})"
    )
    cohort = Cohort(base.atlas, base.faces, subjects, source)
    outcome = None
    if outcome_effect is not None:
        region = next((r.affected for r in regions.values() if r is not None), None)
        time, event, _ = cohort_outcome(cohort, outcome_effect, _child(seed, _OUTCOME_KEY), region)
        outcome = {s.name: {"time": float(f"{t:.6g}"), "event": int(e)}
                   for s, t, e in zip(subjects, time, event)}  # fmt: skip
        outcome_effect = float(outcome_effect)
    return CovariateCohort(cohort, membership, table, regions, specs, covariates, noise, seed,
                           outcome, outcome_effect)  # fmt: skip


def write_covariate_cohort(data: CovariateCohort, folder, ext: str = ".vtk", **options) -> Path:
    """Write the meshes, ``groups.csv``, ``design.csv`` and the truth into ``folder``.

    The meshes, ``groups.csv`` and ``planted_region.json`` are written as by
    :func:`~ladders.study.population.write_two_group_cohort` (same ``options``:
    ``remesh_factor``, ``pose``, ``max_angle``, ``max_translation``, ``rng``,
    ``landmarks``); the truth holds :meth:`CovariateCohort.description` (every group's
    abnormality, anatomy shift and planted region, the covariates' effects).

    Parameters
    ----------
    data : CovariateCohort
    folder : str or Path
    ext : str, default ".vtk"
    **options
        Passed to :func:`~ladders.study.population.write_two_group_cohort`.

    Returns
    -------
    Path
        The folder.
    """
    if not isinstance(data, CovariateCohort):
        raise CohortError(f"data: expected a CovariateCohort, got {type(data).__name__}")
    folder = write_two_group_cohort(data, folder, ext=ext, **options)
    table = pd.DataFrame(data.design_table())
    table.to_csv(folder / DESIGN_FILE, index=False, lineterminator="\n", encoding="utf-8")
    return folder
