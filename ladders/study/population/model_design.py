"""A design table checked against a study's subjects, before any computation.

What ``symladders analyze --design`` and ``symladders cycle-analyze --design`` share:
:func:`check_design_table` matches the table's subjects with the study's (a subject
of the table that the study does not have is an error naming its row; a subject of
the study the table does not list is left out), and :func:`model_design` builds the
model formula's design (:func:`ladders.statistics.design_matrix`) on the kept
subjects, checks every contrast and reads the exchangeability blocks.
:func:`groups_design` writes a two-group comparison as that model (``group``, the
contrast of the two levels).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ladders.statistics import Design, contrast_matrix, design_matrix
from ladders.tables import locate

from ..errors import CohortError

__all__ = ["ModelDesign", "check_design_table", "compared_groups", "groups_design", "model_design"]


def _where(source) -> str:
    return "design" if source is None else str(source)


def check_design_table(
    table: dict, subjects: list[str], source=None, study: str = "the study"
) -> tuple[list[str], list[str]]:
    """The study's subjects in the design, and those left out; raise for design-only subjects.

    Parameters
    ----------
    table : dict of str to list
        A ``subject`` column and the covariates (:func:`ladders.statistics.read_design`).
    subjects : list of str
        The study's subjects, in its order.
    source : str or path, optional
        The table's file, named in the errors (default ``"design"``).
    study : str
        What the study is called in the errors.

    Returns
    -------
    kept : list of str
        The study's subjects listed in the table, in the study's order.
    left_out : list of str
        The study's subjects the table does not list.

    Raises
    ------
    CohortError
        The table has no ``subject`` column, names a subject the study does not have
        (the first one, with its line in the file: the header is line 1), or shares
        fewer than 3 subjects with the study. A table read from a file (a
        :class:`~ladders.tables.TableDict`) names the file, the line and the column.
    """
    where = _where(source)
    if "subject" not in table:
        raise CohortError(f"{where}: no 'subject' column (columns: {', '.join(table)})")
    listed = [str(s).strip() for s in table["subject"]]
    known = set(subjects)
    unknown = [(i, s) for i, s in enumerate(listed) if s not in known]
    if unknown:
        line, name = unknown[0][0] + 2, unknown[0][1]
        place = locate(table, "subject", name, f"{where}, line {line}")
        more = f" (and {len(unknown) - 1} more)" if len(unknown) > 1 else ""
        raise CohortError(
            f"{place}: unknown subject {name!r}, not in {study} (it has {len(subjects)} "
            f"subjects with results){more}"
        )
    chosen = set(listed)
    kept = [s for s in subjects if s in chosen]
    left_out = [s for s in subjects if s not in chosen]
    if len(kept) < 3:
        raise CohortError(f"{where}: {len(kept)} subject(s) shared with {study}, need at least 3")
    return kept, left_out


@dataclass(frozen=True)
class ModelDesign:
    """A model's design on the subjects of a study, its contrasts checked.

    Attributes
    ----------
    design : Design
        On ``kept``, in the study's order.
    contrasts : list of str
        As given (each checked by :func:`ladders.statistics.contrast_matrix`).
    blocks : ndarray of str, shape (n,), or None
        The exchangeability block of each kept subject.
    kept, left_out : list of str
        The study's subjects in the design, and those it does not list.
    """

    design: Design
    contrasts: list
    blocks: np.ndarray | None
    kept: list
    left_out: list


def model_design(
    table: dict,
    formula: str,
    contrasts,
    subjects,
    blocks: str | None = None,
    source=None,
    study: str = "the study",
) -> ModelDesign:
    """The design of ``formula`` on the study's subjects, its contrasts and blocks checked.

    Parameters
    ----------
    table : dict of str to list
    formula : str
        E.g. ``"group + age + sex"``.
    contrasts : list of str
        E.g. ``["group[patients] - group[controls]", "age", "group"]``.
    subjects : list of str
        The study's subjects in its order.
    blocks : str, optional
        A column of the table holding each subject's exchangeability block.
    source, study : see :func:`check_design_table`

    Returns
    -------
    ModelDesign

    Raises
    ------
    CohortError
        One line naming the file and what is wrong: a subject, a formula's column, a
        missing or non-numeric value, a contrast's term or level, the blocks' column.
    """
    where = _where(source)
    if not contrasts:
        raise CohortError("contrast: give at least one contrast")
    kept, left_out = check_design_table(table, list(subjects), source, study)
    try:
        design = design_matrix(table, formula, subjects=kept)
    except ValueError as exc:
        raise CohortError(f"{where}: {exc}") from None
    for spec in contrasts:  # every contrast checked before any computation
        try:
            contrast_matrix(design, spec)
        except ValueError as exc:
            reason = str(exc).removeprefix("contrast: ")
            raise CohortError(f"{where}: --contrast {spec!r}: {reason}") from None
    labels = None
    if blocks is not None:
        if blocks not in table:
            raise CohortError(
                f"{where}: blocks: no column {blocks!r} (columns: {', '.join(table)})"
            )
        by_subject = dict(zip([str(s).strip() for s in table["subject"]], table[blocks]))
        labels = np.array([str(by_subject[s]).strip() for s in kept])
        empty = [s for s, b in zip(kept, labels) if not b]
        if empty:
            raise CohortError(f"{where}: column {blocks!r}: no block for subject {empty[0]!r}")
    return ModelDesign(design, list(contrasts), labels, kept, left_out)


def compared_groups(groups: dict, compare: tuple | None = None) -> tuple[str, str]:
    """The two groups of a groups table to compare, the first tested against the second.

    Parameters
    ----------
    groups : dict
        ``{subject: group}``.
    compare : (str, str), optional
        Required when the table has more than two groups; default the table's two
        groups in the order they first appear.

    Raises
    ------
    CohortError
        Not two groups without ``compare``, two equal names, or a group absent.
    """
    present = list(dict.fromkeys(str(g) for g in groups.values()))
    if compare is None:
        if len(present) != 2:
            raise CohortError(
                f"groups: expected two groups, the table has {len(present)}: {present}"
                + ("; name the two to compare (--compare A,B)" if len(present) > 2 else "")
            )
        compare = (present[0], present[1])
    compare = tuple(str(g) for g in compare)
    if len(compare) != 2 or compare[0] == compare[1]:
        raise CohortError(f"compare: expected two different groups, got {compare}")
    missing = [g for g in compare if g not in present]
    if missing:
        raise CohortError(f"compare: group(s) {missing} not in the table (it has {present})")
    return compare


def groups_design(groups: dict, compare: tuple | None = None) -> tuple[dict, str, list[str]]:
    """A two-group comparison as a linear model: the table, the formula and the contrast.

    Parameters
    ----------
    groups : dict
        ``{subject: group}`` (:func:`~ladders.study.cohort.read_groups`).
    compare : (str, str), optional
        The two groups, the first tested against the second; required when the table
        has more than two groups (the subjects of the others are left out). Default:
        the table's two groups in the order they first appear.

    Returns
    -------
    table : dict
        The columns ``subject`` and ``group`` of the two groups' subjects.
    formula : str
        ``"group"``.
    contrasts : list of str
        ``["group[A] - group[B]"]``.

    Raises
    ------
    CohortError
        As :func:`compared_groups`.
    """
    compare = compared_groups(groups, compare)
    kept = [s for s, g in groups.items() if str(g) in compare]
    table = {"subject": kept, "group": [str(groups[s]) for s in kept]}
    return table, "group", [f"group[{compare[0]}] - group[{compare[1]}]"]
