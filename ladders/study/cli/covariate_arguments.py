"""The cohort in several groups with covariates, from ``symladders cohort``'s flags.

Shared by the ED-ES cohort (:mod:`.cohort_cli`) and the cohort through the whole cycle
(:mod:`.cohort_cycle_cli`): :func:`several_groups` says whether the flags ask for it
(``--group``, ``--anatomy``, ``--imbalance``, ``--age-effect``, ``--sex-effect``,
``--body-size-sd``, ``--outcome-effect``, ``--design``), :func:`covariate_data` draws it
(:func:`~ladders.study.population.make_covariate_cohort`) and
:func:`print_covariate_cohort` reports it.
"""

from __future__ import annotations

from dataclasses import replace

from .cli_types import UsageError

__all__ = ["COVARIATE_OPTIONS", "covariate_data", "print_covariate_cohort", "several_groups"]

#: The covariate model's flags (attributes of the parsed arguments).
COVARIATE_OPTIONS = ("imbalance", "age_effect", "sex_effect", "body_size_sd")


def several_groups(args) -> bool:
    """Whether the flags ask for the cohort in several groups with covariates."""
    return (
        bool(args.group or args.anatomy or args.design)
        or getattr(args, "outcome_effect", None) is not None
        or any(getattr(args, k) is not None for k in COVARIATE_OPTIONS)
    )


def covariate_data(args, abnormality, transition_height: float | None = None) -> tuple:
    """The cohort in several groups of the parsed flags, and its groups.

    Parameters
    ----------
    args : argparse.Namespace
    abnormality : MotionAbnormality or None
        The patients' (``--effect``), when no ``--group`` is given.
    transition_height : float, optional
        Every group's abnormality with this ring transition (the whole cycle's images
        need wide transitions to stay invertible).

    Returns
    -------
    (CovariateCohort, list of CohortGroup)
    """
    from ..cohort.planted_effect import MotionAbnormality
    from ..errors import CohortError
    from ..population import (
        AnatomyShift,
        CohortGroup,
        Covariates,
        make_covariate_cohort,
    )

    try:
        if args.group:
            specs = [(name, None if kind is None else MotionAbnormality(
                kind, segments or (7, 8, 13, 14), magnitude)) for name, kind, segments, magnitude
                in args.group]  # fmt: skip
        else:
            specs = [("controls", None), ("patients", abnormality)]
        if transition_height is not None:
            specs = [(name, None if effect is None else
                      replace(effect, transition_height=transition_height))
                     for name, effect in specs]  # fmt: skip
        names = [name for name, _ in specs]
        shifts = {}
        for name, fields in args.anatomy or []:
            if name not in names:
                raise CohortError(f"--anatomy {name}: no such group (groups: {', '.join(names)})")
            shifts[name] = AnatomyShift(**fields)
        groups = [CohortGroup(name, effect, shifts.get(name)) for name, effect in specs]
        options = {k: getattr(args, k) for k in COVARIATE_OPTIONS if getattr(args, k) is not None}
        covariates = Covariates(**options)
        n = len(groups)
        sizes = [args.subjects // n + (i < args.subjects % n) for i in range(n)]
        data = make_covariate_cohort(sizes, groups, covariates, args.seed, args.vertices,
                                     args.noise, args.noise_length,
                                     outcome_effect=args.outcome_effect)  # fmt: skip
    except CohortError as exc:
        raise UsageError(f"symladders cohort: error: {exc}") from None
    return data, groups


def print_covariate_cohort(data, groups, folder, what: str) -> None:
    """The cohort's groups, their sizes and planted effects (``what``: its vertices, frames)."""
    counts = ", ".join(f"{g.name} {sum(v == g.name for v in data.groups.values())}" for g in groups)
    print(f"symladders cohort: {len(data.cohort)} subjects ({counts}), {what}, in {folder}")
    for g in groups:
        region = data.regions[g.name]
        planted = [] if g.abnormality is None else [
            f"{g.abnormality.describe()} ({int(region.affected.sum())} atlas vertices)"]  # fmt: skip
        planted += [] if g.anatomy is None else [f"anatomy {g.anatomy}"]
        print(f"  {g.name}: {'; '.join(planted) or 'no planted effect'}")
    if data.outcome is not None:
        events = sum(o["event"] for o in data.outcome.values())
        print(f"  outcome: log hazard ratio {data.outcome_effect:g} per SD of the regional "
              f"motion, {events} events")  # fmt: skip
