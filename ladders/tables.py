"""The one reader of the input tables (CSV files with a header line) the commands take.

Every input table (groups, design, landmarks, cut planes, a cohort's mesh paths,
frames) is read by :func:`read_table` with the table's declared columns, and every
refusal is one line naming the file, the line (the file's line number, the header
being line 1) and the column:

* a missing required column, a column named twice, or a column the table's reader
  would ignore;
* a row with more cells than the header;
* an empty required value, or a value that is not what its column holds (a finite
  number, an integer, a frame index >= 0);
* a second row with the same key (e.g. a second plane for one image and frame).

What only the caller knows is checked on the table read, naming the line too:
:meth:`Table.refuse_unknown` (a subject that is not in the cohort) and
:meth:`Table.refuse_beyond` (a frame outside its series).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Column", "Table", "TableError", "TableDict", "read_table", "locate"]


class TableError(ValueError):
    """An input table that cannot be used; the message names the file, line and column."""


def _text(value: str) -> str:
    return value


def _number(value: str) -> float:
    number = float(value)
    if not math.isfinite(number):
        raise ValueError
    return number


def _integer(value: str) -> int:
    return int(value)


def _frame(value: str) -> int:
    frame = int(value)
    if frame < 0:
        raise ValueError
    return frame


#: The kinds of values a column holds: a parser each and the words of its refusal.
KINDS: dict[str, tuple[Callable[[str], object], str]] = {
    "text": (_text, "a text"),
    "number": (_number, "a finite number"),
    "integer": (_integer, "an integer"),
    "frame": (_frame, "a frame index (an integer >= 0, 0-based)"),
}


@dataclass(frozen=True)
class Column:
    """A column of a table: its name (matched without regard to letter case or the spaces
    around it), the kind of its values (a key of :data:`KINDS`), whether it is required,
    and the value of an empty cell of an optional column (``None``: kept empty)."""

    name: str
    kind: str = "text"
    required: bool = True
    empty: object = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(
                f"Column {self.name!r}: kind {self.kind!r} is not one of {list(KINDS)}"
            )


@dataclass
class Table:
    """The rows of a table read by :func:`read_table`.

    Attributes
    ----------
    path : Path
    what : str
        What the table is, as the messages name it (e.g. ``"groups table"``).
    columns : tuple of str
        The columns present, in the file's order (declared names, lower case; extra
        columns as written when they are kept).
    rows : list of dict
        One per data row: ``{column: value}`` (values parsed by their column's kind).
    lines : list of int
        The file line of every row (the header is line 1).
    error_type : type
        The exception its refusals raise (:class:`TableError` or the caller's, a
        ``ValueError``).
    """

    path: Path
    what: str
    columns: tuple
    rows: list = field(default_factory=list)
    lines: list = field(default_factory=list)
    error_type: type = TableError

    def __len__(self) -> int:
        return len(self.rows)

    def where(self, index: int, column: str | None = None) -> str:
        """``"<what> <path>, line <n>, column '<c>'"`` of row ``index`` (0-based)."""
        place = f"{self.what} {self.path}, line {self.lines[index]}"
        return place if column is None else f"{place}, column {column!r}"

    def error(self, index: int, column: str | None, problem: str) -> ValueError:
        """The table's error (:attr:`error_type`) naming row ``index`` (0-based) and ``column``."""
        return self.error_type(f"{self.where(index, column)}: {problem}")

    def column(self, name: str) -> list:
        """The values of one column, in the rows' order."""
        return [row.get(name) for row in self.rows]

    def refuse_unknown(self, column: str, known: Collection, what: str = "subject") -> None:
        """Refuse the first row whose ``column`` is not in ``known`` (e.g. the cohort's
        subjects), naming its line and a few of the known values."""
        for i, row in enumerate(self.rows):
            if row[column] not in known:
                names = sorted(map(str, known))
                shown = ", ".join(names[:6]) + (
                    f" and {len(names) - 6} more" if len(names) > 6 else ""
                )
                raise self.error(
                    i, column, f"unknown {what} {row[column]!r} (known: {shown or 'none'})"
                )

    def refuse_beyond(self, column: str, limits: Mapping, key: str, what: str = "series") -> None:
        """Refuse the first row whose ``column`` (an index) is not below ``limits[row[key]]``
        (e.g. a frame beyond its series' frame count); rows whose key has no limit pass."""
        for i, row in enumerate(self.rows):
            value, limit = row.get(column), limits.get(row[key])
            if value is not None and limit is not None and not 0 <= value < limit:
                raise self.error(
                    i, column, f"{column} {value} is outside the {what} {row[key]!r} "
                    f"({limit} frames: 0 to {limit - 1})",
                )  # fmt: skip


class TableDict(dict):
    """A dict made from a table (e.g. ``{subject: group}``, or ``{column: values}``) that
    keeps the :class:`Table` it was read from (``table``), so that a check made later on the
    dict can name the line of the value it refuses (:func:`locate`)."""

    def __init__(self, items, table: Table | None = None):
        super().__init__(items)
        self.table = table


def locate(data, column: str, value, fallback: str) -> str:
    """``"<what> <path>, line <n>, column '<column>'"`` of the first row of ``data``'s table
    whose ``column`` is ``value``; ``fallback`` when ``data`` was not read from a table (a
    :class:`TableDict`) or has no such row."""
    table = getattr(data, "table", None)
    for i, row in enumerate(table.rows if table is not None else []):
        if row.get(column) == value:
            return table.where(i, column)
    return fallback


def _header(path: Path, what: str, header: list[str], columns: Sequence[Column], extra: bool):
    names = [h.strip() for h in header]
    lowered = [n.lower() for n in names]
    for i, name in enumerate(lowered):
        if not name:
            raise TableError(f"{what} {path}, line 1: column {i + 1} has no name")
        if name in lowered[:i]:
            raise TableError(f"{what} {path}, line 1, column {names[i]!r}: named twice")
    declared = {c.name for c in columns}
    expected = ",".join(c.name if c.required else f"[{c.name}]" for c in columns)
    missing = [c.name for c in columns if c.required and c.name not in lowered]
    if missing:
        raise TableError(
            f"{what} {path}, line 1: missing column {missing[0]!r} (expected the columns "
            f"{expected}; found {','.join(names)})"
        )
    if not extra:
        unused = [n for n, low in zip(names, lowered) if low not in declared]
        if unused:
            raise TableError(
                f"{what} {path}, line 1, column {unused[0]!r}: not used by this table (its "
                f"columns are {expected}); remove it"
            )
    return [low if low in declared else name for name, low in zip(names, lowered)]


def read_table(
    path,
    columns: Sequence[Column],
    *,
    what: str,
    key: Iterable[str] = (),
    extra: bool = False,
    text: str | None = None,
    error: type = TableError,
) -> Table:
    """Read a CSV table with a header line, refusing what it cannot use (see the module).

    Parameters
    ----------
    path : str or Path
        The file (named in every message).
    columns : sequence of Column
        The declared columns (lower-case names).
    what : str
        What the table is, e.g. ``"groups table"`` (the messages start with it).
    key : iterable of str
        Columns whose values identify a row: a second row with the same values is
        refused (an optional key column's empty value counts as a value).
    extra : bool, default False
        Keep the columns not declared (as text; e.g. a design table's covariates)
        instead of refusing them.
    text : str, optional
        The table's text, already read (``path`` then only names it).
    error : type, default TableError
        The exception raised (a subclass of ``ValueError``, e.g. the caller's own), also
        by the :class:`Table`'s checks.

    Returns
    -------
    Table

    Raises
    ------
    TableError
        (Or ``error``.) One line naming the file, the line and the column (see the
        module); an unreadable file or a table without data rows.
    """
    try:
        table = _read(Path(path), tuple(columns), what, tuple(key), extra, text)
    except TableError as exc:
        if error is TableError:
            raise
        raise error(str(exc)) from None
    table.error_type = error
    return table


def _read(path: Path, columns, what: str, key: tuple, extra: bool, text: str | None) -> Table:
    if text is None:
        try:
            text = path.read_text(encoding="utf-8-sig")
        except (OSError, UnicodeDecodeError) as exc:
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
            raise TableError(f"{what} {path}: cannot be read ({reason})") from None
    reader = csv.reader(io.StringIO(text.removeprefix("\ufeff")), skipinitialspace=True)
    try:
        header = next(reader, None)
        if header is None or not any(h.strip() for h in header):
            raise TableError(f"{what} {path}: empty file, expected a header line")
        names = _header(path, what, header, columns, extra)
        kinds = {c.name: c for c in columns}
        table = Table(path, what, tuple(names))
        seen: dict[tuple, int] = {}
        for cells in reader:
            line = reader.line_num
            if not any(c.strip() for c in cells):
                continue
            if len(cells) > len(names):
                raise TableError(
                    f"{what} {path}, line {line}: {len(cells)} values for {len(names)} columns"
                )
            row = {}
            for name, cell in zip(names, [*cells, *[""] * (len(names) - len(cells))]):
                row[name] = _value(path, what, line, kinds.get(name), name, cell.strip())
            for c in columns:
                row.setdefault(c.name, c.empty)
            if key:
                ident = tuple(row[k] for k in key)
                if ident in seen:
                    shown = ", ".join(f"{k} {v!r}" for k, v in zip(key, ident) if v is not None)
                    raise TableError(
                        f"{what} {path}, line {line}, column {key[0]!r}: a second row for "
                        f"{shown} (the first is line {seen[ident]})"
                    )
                seen[ident] = line
            table.rows.append(row)
            table.lines.append(line)
    except csv.Error as exc:
        raise TableError(
            f"{what} {path}, line {reader.line_num}: not a CSV table ({exc})"
        ) from None
    if not table.rows:
        raise TableError(f"{what} {path}: no data row below the header")
    return table


def _value(path, what, line, column: Column | None, name: str, cell: str):
    if column is None:  # a kept extra column
        return cell
    if not cell:
        if column.required:
            raise TableError(f"{what} {path}, line {line}, column {name!r}: empty value")
        return column.empty
    parse, expected = KINDS[column.kind]
    try:
        return parse(cell)
    except ValueError:
        raise TableError(
            f"{what} {path}, line {line}, column {name!r}: expected {expected}, got {cell!r}"
        ) from None
