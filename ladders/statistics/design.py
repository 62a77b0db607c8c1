"""Design matrices from a table of subjects and a model formula, and contrasts by name.

:func:`design_matrix` builds the matrix ``X`` ``(n, p)`` of a general linear model from
a table with one row per subject (a ``subject`` column and the covariates) and a
right-hand-side formula such as ``"group + age + sex"`` (`formulaic`_ syntax).
Columns of strings are factors, coded against a reference level (treatment coding);
numeric columns enter as they are. The table is checked before anything is computed,
and each problem is reported on one line naming the column, the subject or the value.

:func:`contrast_matrix` turns a contrast written with the names of the table, e.g.
``"group[patients] - group[controls]"``, ``"age"`` or ``"group"`` (every level of a
factor at once), into the matrix ``C`` ``(q, p)`` of the hypothesis ``C beta = 0``.

.. _formulaic: https://matthewwardrop.github.io/formulaic/
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from formulaic import Formula, model_matrix
from scipy import linalg

from ladders.tables import Column, TableDict, read_table

__all__ = ["Design", "design_matrix", "contrast_matrix", "read_design"]


@dataclass(frozen=True)
class Design:
    """A design matrix with the names of its columns and of its subjects.

    Attributes
    ----------
    matrix : ndarray, shape (n, p), float64
        One row per subject, one column per regressor.
    columns : list of str
        The regressors' names as formulaic writes them (``Intercept``,
        ``group[T.patients]``, ``age``, ``group[T.patients]:age``).
    subjects : list of str
        The subject of each row.
    formula : str
        The right-hand side the matrix was built from.
    factors : dict of str to list of str
        The levels of each categorical variable, the reference level first.
    model_spec : formulaic.ModelSpec
        The model specification (e.g. to encode new subjects with the same coding).
    """

    matrix: np.ndarray
    columns: list[str]
    subjects: list[str]
    formula: str
    factors: dict[str, list[str]]
    model_spec: Any = field(default=None, repr=False, compare=False)

    @property
    def shape(self) -> tuple[int, int]:
        """``(n, p)``: subjects and regressors."""
        return self.matrix.shape


def _missing(value) -> bool:
    if value is None:
        return True
    if isinstance(value, str):
        return value.strip() == ""
    try:
        return bool(pd.isna(value))
    except (TypeError, ValueError):
        return False


def _as_number(value) -> float | None:
    if isinstance(value, bool | np.bool_):
        return float(value)
    if isinstance(value, int | float | np.integer | np.floating):
        return float(value)
    try:
        return float(str(value).strip())
    except ValueError:
        return None


def _as_frame(table) -> pd.DataFrame:
    if isinstance(table, pd.DataFrame):
        frame = table.copy()
    elif isinstance(table, dict):
        lengths = {name: len(values) for name, values in table.items()}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"table: columns of different lengths {lengths}")
        frame = pd.DataFrame({name: list(values) for name, values in table.items()}, dtype=object)
    else:
        raise ValueError(f"table: expected a dict of columns or a DataFrame, got {type(table)}")
    if "subject" not in frame.columns:
        raise ValueError(f"table: no 'subject' column (columns: {', '.join(map(str, frame))})")
    return frame


def _formula_variables(formula: str, available: list[str]) -> tuple[str, list[str]]:
    text = formula.strip()
    if not text.startswith("~") and "~" in text:
        raise ValueError(f"formula: {formula!r} has a left-hand side; write only '~ terms'")
    text = text.lstrip("~").strip()
    try:
        variables = sorted(Formula(text).required_variables)
    except Exception as error:  # formulaic raises several parser exceptions
        raise ValueError(f"formula: cannot parse {formula!r} ({error})") from None
    unknown = [v for v in variables if v not in available]
    if unknown:
        raise ValueError(
            f"formula: unknown column {', '.join(map(repr, unknown))} "
            f"(available: {', '.join(available)})"
        )
    return text, variables


def _select_subjects(frame: pd.DataFrame, subjects) -> pd.DataFrame:
    names = [str(s) for s in frame["subject"]]
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise ValueError(f"table: subject {name!r} is listed twice")
        seen.add(name)
    frame = frame.assign(subject=names).set_index("subject", drop=False)
    if subjects is None:
        return frame
    wanted = [str(s) for s in subjects]
    if len(set(wanted)) < len(wanted):
        twice = next(s for s in wanted if wanted.count(s) > 1)
        raise ValueError(f"subjects: subject {twice!r} is listed twice")
    absent = [s for s in wanted if s not in seen]
    if absent:
        raise ValueError(f"subjects: {', '.join(map(repr, absent))} not in the table")
    return frame.loc[wanted]


def _clean_column(frame: pd.DataFrame, name: str, reference: dict) -> tuple[pd.Series, list | None]:
    """The column as floats or as an ordered categorical (its levels, reference first)."""
    values = list(frame[name])
    for subject, value in zip(frame["subject"], values):
        if _missing(value):
            raise ValueError(f"column {name!r}: missing value for subject {subject!r}")
    numbers = [_as_number(v) for v in values]
    n_numeric = sum(x is not None for x in numbers)
    if n_numeric == len(values) and name not in reference:
        column = pd.Series(numbers, index=frame.index, dtype=np.float64)
        if np.ptp(column.to_numpy()) == 0:
            raise ValueError(f"column {name!r} is constant (all {values[0]!r})")
        return column, None
    if 2 * n_numeric > len(values) and name not in reference:
        subject, value = next(
            (s, v) for s, v, x in zip(frame["subject"], values, numbers) if x is None
        )
        raise ValueError(f"column {name!r}: non-numeric value {value!r} for subject {subject!r}")
    labels = [str(v).strip() for v in values]
    levels = sorted(set(labels))
    if len(levels) < 2:
        raise ValueError(f"column {name!r} is constant (all {labels[0]!r})")
    if name in reference:
        ref = str(reference[name])
        if ref not in levels:
            raise ValueError(
                f"reference: level {ref!r} of column {name!r} not found "
                f"(levels: {', '.join(levels)})"
            )
        levels = [ref] + [level for level in levels if level != ref]
    return pd.Series(pd.Categorical(labels, categories=levels), index=frame.index), levels


def _collinear_columns(matrix: np.ndarray, columns: list[str]) -> list[str]:
    scale = np.linalg.norm(matrix, axis=0)
    null = linalg.null_space(matrix / np.where(scale > 0, scale, 1.0), rcond=1e-10)
    involved = np.abs(null).max(axis=1) > 1e-8
    return [c for c, inv in zip(columns, involved) if inv]


def design_matrix(
    table: dict[str, list] | pd.DataFrame,
    formula: str,
    subjects: list[str] | None = None,
    reference: dict[str, str] | None = None,
) -> Design:
    """The design matrix of ``formula`` on the subjects of ``table``.

    Parameters
    ----------
    table : dict of str to list, or pandas.DataFrame
        One row per subject: a ``subject`` column and the covariates. Columns of
        numbers (or numeric strings) are continuous; other columns are factors.
    formula : str
        Right-hand side in formulaic syntax, e.g. ``"group + age + sex"`` or
        ``"~ group * age"``; an intercept is included unless removed (``0 + ...``).
    subjects : list of str, optional
        The subjects and their order (the rows of the responses); default: the
        table's rows in order.
    reference : dict of str to str, optional
        The reference level of a factor (default: its first level in sorted order).
        A numeric column named here is treated as a factor.

    Returns
    -------
    Design
        ``matrix`` ``(n, p)`` float64 with full column rank.

    Raises
    ------
    ValueError
        Naming the culprit: a formula naming an unknown column, a subject listed
        twice (or absent), a missing value, a non-numeric value in an otherwise
        numeric column, a constant column, or collinear columns of the design.
    """
    frame = _as_frame(table)
    reference = dict(reference or {})
    text, variables = _formula_variables(str(formula), [str(c) for c in frame.columns])
    for name in reference:
        if name not in variables:
            raise ValueError(f"reference: column {name!r} is not in the formula {formula!r}")
    frame = _select_subjects(frame, subjects)
    data, factors = {}, {}
    for name in variables:
        data[name], levels = _clean_column(frame, name, reference)
        if levels is not None:
            factors[name] = levels
    clean = pd.DataFrame(data, index=frame.index)
    built = model_matrix(text, clean, na_action="raise")
    matrix = np.ascontiguousarray(built.to_numpy(dtype=np.float64))
    columns = [str(c) for c in built.columns]
    rank = np.linalg.matrix_rank(matrix)
    if rank < matrix.shape[1]:
        involved = _collinear_columns(matrix, columns)
        raise ValueError(
            f"design: columns {', '.join(map(repr, involved))} are collinear "
            f"(rank {rank} < {matrix.shape[1]} columns)"
        )
    return Design(matrix, columns, list(frame["subject"]), text, factors, built.model_spec)


_TERM = re.compile(r"^\s*(?:(\d+(?:\.\d*)?|\.\d+)\s*\*?\s*)?(.+?)\s*$")


def _split_terms(spec: str) -> list[tuple[float, str]]:
    """``"a - 2*b[x] + c"`` as ``[(1, "a"), (-1, "2*b[x]"), (1, "c")]`` (brackets kept whole)."""
    terms, depth, sign, start = [], 0, 1.0, 0
    for i, char in enumerate(spec + "+"):
        depth += {"[": 1, "(": 1, "]": -1, ")": -1}.get(char, 0)
        if depth == 0 and char in "+-" and (i == len(spec) or spec[start:i].strip()):
            terms.append((sign, spec[start:i]))
            sign, start = (1.0 if char == "+" else -1.0), i + 1
        elif depth == 0 and char in "+-":
            sign, start = sign * (1.0 if char == "+" else -1.0), i + 1
    return terms


def _factor_of(prefix: str, factors: dict) -> str | None:
    if prefix in factors:
        return prefix
    inner = re.match(r"^C\(\s*(\w+)\s*(,.*)?\)$", prefix)
    return inner.group(1) if inner and inner.group(1) in factors else None


def _term_vector(design: Design, term: str) -> np.ndarray:
    columns, p = design.columns, len(design.columns)
    vector = np.zeros(p)
    if term in columns:
        vector[columns.index(term)] = 1.0
        return vector
    match = re.match(r"^(.+)\[(.+)\]$", term)
    if match:
        prefix, level = match.group(1).strip(), match.group(2).strip()
        factor = _factor_of(prefix, design.factors)
        for name in (f"{prefix}[T.{level}]", f"{prefix}[{level}]"):
            if name in columns:
                vector[columns.index(name)] = 1.0
                return vector
        if factor is not None:
            levels = design.factors[factor]
            if level == levels[0] and any(c.startswith(f"{prefix}[T.") for c in columns):
                return vector  # the reference level: its effect is zero
            raise ValueError(
                f"contrast: unknown level {level!r} of {prefix!r} (levels: {', '.join(levels)})"
            )
    known = ", ".join(columns)
    factor_names = ", ".join(design.factors) or "none"
    raise ValueError(f"contrast: unknown term {term!r} (columns: {known}; factors: {factor_names})")


def contrast_matrix(design: Design, spec) -> tuple[str, np.ndarray]:
    """The contrast matrix ``C`` ``(q, p)`` of a contrast written by name, and its name.

    Parameters
    ----------
    design : Design
    spec : str or array, shape (q, p) or (p,)
        ``"group[patients] - group[controls]"``: difference of two levels;
        ``"group[patients]"``: a level against the reference; ``"age"``: the slope of
        a continuous variable; any column name, e.g. ``"group[T.patients]:age"``;
        terms may be combined with ``+``, ``-`` and numeric weights (``"0.5*a"``);
        ``"group"`` (a factor's name): the F test over all its levels, one row per
        non-reference level. An array is used as it is.

    Returns
    -------
    name : str
    C : ndarray, shape (q, p), float64
        Full row rank.

    Raises
    ------
    ValueError
        Naming an unknown column or level (with the known ones), or a contrast
        that is zero or whose rows are linearly dependent.
    """
    p = len(design.columns)
    if isinstance(spec, str):
        name = spec.strip()
        prefix_columns = [c for c in design.columns if c.startswith(f"{name}[") and ":" not in c]
        if _factor_of(name, design.factors) is not None and name not in design.columns:
            if not prefix_columns:
                raise ValueError(f"contrast: factor {name!r} has no main-effect column")
            levels = design.factors[_factor_of(name, design.factors)]
            treatment = [c for c in prefix_columns if c.startswith(f"{name}[T.")]
            rows = [_term_vector(design, c) for c in treatment] or [
                _term_vector(design, f"{name}[{level}]")
                - _term_vector(design, f"{name}[{levels[0]}]")
                for level in levels[1:]
            ]
            matrix = np.array(rows)
        else:
            matrix = np.zeros((1, p))
            for sign, text in _split_terms(name):
                if not text.strip():
                    raise ValueError(f"contrast: {name!r} has an empty term")
                weight, term = _TERM.match(text).groups()
                matrix[0] += sign * float(weight or 1.0) * _term_vector(design, term)
    else:
        name = "contrast"
        matrix = np.atleast_2d(np.asarray(spec, dtype=np.float64))
        if matrix.ndim != 2 or matrix.shape[1] != p or not np.isfinite(matrix).all():
            raise ValueError(
                f"contrast: expected a finite array (q, {p}) for the columns "
                f"{', '.join(design.columns)}, got shape {np.shape(spec)}"
            )
    if not np.any(matrix):
        raise ValueError(f"contrast: {name!r} is zero (it compares a level with itself?)")
    if np.linalg.matrix_rank(matrix) < matrix.shape[0]:
        raise ValueError(f"contrast: the rows of {name!r} are linearly dependent")
    return name, matrix


def read_design(path) -> dict[str, list]:
    """The table of a CSV file (a header line; one row per subject) as a dict of columns.

    Read by :func:`ladders.tables.read_table`: a ``subject`` column, each subject once,
    and any covariates (kept as text; :func:`design_matrix` reads the numbers). The dict
    is a :class:`~ladders.tables.TableDict`: a later check names the line of a subject.

    Raises
    ------
    ladders.tables.TableError
        A ``ValueError`` naming the file, the line and the column: an unreadable file, no
        ``subject`` column, an empty or repeated subject, a row longer than the header.
    """
    table = read_table(path, (Column("subject"),), what="design table", key=("subject",),
                       extra=True)  # fmt: skip
    return TableDict(((name, table.column(name)) for name in table.columns), table)
