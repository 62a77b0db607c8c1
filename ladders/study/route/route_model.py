"""The linear model a subjects table implies: its formula and contrasts, by a stated rule.

* The formula is the settings' ``model.formula``, else every covariate column of the
  table in its order, ``group`` first (``group + age + sex``).
* The contrasts are the settings' ``model.contrasts``, else: with a ``group`` column
  of two levels, the other level against the reference (``group[patients] -
  group[controls]``); of three levels or more, the F test over the levels
  (``group``) and each level against the reference; without a group, every
  covariate of the formula (a t test for a number, an F test for a category).
* The reference group is ``model.reference``, else the first level in sorted order
  (the reference :func:`~ladders.statistics.design_matrix` takes).
"""

from __future__ import annotations

from dataclasses import dataclass

from .route_settings import RouteSettingsError
from .subjects_table import SubjectsTable, SubjectsTableError

__all__ = ["RouteModel", "route_model", "formula_columns"]


@dataclass(frozen=True)
class RouteModel:
    """The model of a route.

    Attributes
    ----------
    formula : str or None
        None: the table has no covariate, there is nothing to test.
    contrasts : list of str
    groups : list of str
        The levels of ``group``, the reference first (empty without a group column).
    columns : list of str
        The table's columns the formula uses.
    """

    formula: str | None
    contrasts: list
    groups: list
    columns: list

    @property
    def reference(self) -> str | None:
        return self.groups[0] if self.groups else None


def formula_columns(formula: str) -> list[str]:
    """The variables a formula names, e.g. ``['age', 'group']`` for ``group * age``."""
    from formulaic import Formula

    text = formula.strip().lstrip("~").strip()
    try:
        return sorted(Formula(text).required_variables)
    except Exception as exc:  # noqa: BLE001 - formulaic raises several parser exceptions
        raise ValueError(f"cannot parse the formula {formula!r} ({exc})") from None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def route_model(table: SubjectsTable, settings) -> RouteModel:
    """The formula and contrasts of ``table`` under ``settings`` (see the module).

    Raises
    ------
    RouteSettingsError
        A formula naming a column the table lacks, a reference that is not a group.
    """
    given = settings["model"]
    path = settings.path
    extra = [c for c in (given["blocks"], *(given["outcome"] or ())) if c is not None]
    for column in extra:
        if column not in table.covariates:
            raise RouteSettingsError(
                f"settings {path}, model: column {column!r} is not a column of the subjects "
                f"table {table.path} (or it is listed under model.ignore)"
            )
    formula = given["formula"]
    if formula is None:
        columns = [c for c in table.covariates if c not in extra]
        columns.sort(key=lambda c: c != "group")
        formula = " + ".join(columns) if columns else None
    else:
        try:
            columns = formula_columns(formula)
        except ValueError as exc:
            raise RouteSettingsError(f"settings {path}, model.formula: {exc}") from None
        missing = [c for c in columns if c not in table.covariates]
        if missing:
            raise RouteSettingsError(
                f"settings {path}, model.formula: column {missing[0]!r} is not a covariate of "
                f"the subjects table {table.path} (covariates: {', '.join(table.covariates)})"
            )
    for column in table.covariates:
        if column not in columns and column not in extra:
            raise SubjectsTableError(
                f"subjects table {table.path}, line 1, column {column!r}: not in the model "
                f"{formula!r}: this column would be ignored; add it to model.formula, or list "
                "it under model.ignore"
            )
    groups = []
    if "group" in columns:
        levels = sorted(set(table.column("group")))
        reference = given["reference"] or levels[0]
        if reference not in levels:
            raise RouteSettingsError(
                f"settings {path}, model.reference: {reference!r} is not a group of the "
                f"subjects table (groups: {', '.join(levels)})"
            )
        groups = [reference] + [g for g in levels if g != reference]
    elif given["reference"] is not None:
        raise RouteSettingsError(f"settings {path}, model.reference: the model has no 'group'")
    contrasts = given["contrasts"]
    if contrasts is None and formula is not None:
        if len(groups) == 2:
            contrasts = [f"group[{groups[1]}] - group[{groups[0]}]"]
        elif len(groups) > 2:
            contrasts = ["group"] + [f"group[{g}] - group[{groups[0]}]" for g in groups[1:]]
        else:
            contrasts = [c for c in columns]
    return RouteModel(formula, list(contrasts or []), groups, columns)


def numeric_columns(table: SubjectsTable) -> list[str]:
    """The covariate columns whose every cell is a number."""
    return [c for c in table.covariates if all(_is_number(v) for v in table.column(c))]
