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
from .covariate_model import AnatomyShift, Covariates, number
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
    noise = number(noise, "noise", 0.0, np.inf)
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
