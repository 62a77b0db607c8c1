"""The groups table: which group each subject belongs to (``subject,group`` CSV).

Written next to the meshes by ``symladders cohort`` and read by ``symladders
analyze --groups``. Columns ``subject`` and ``group`` (any order and letter case;
other columns are ignored); one row per subject.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from ..errors import CohortError

__all__ = ["read_groups", "groups_csv"]


def groups_csv(groups: dict[str, str]) -> str:
    """The CSV text of ``{subject: group}``, in the dictionary's order."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["subject", "group"])
    for subject, group in groups.items():
        writer.writerow([subject, group])
    return out.getvalue()


def read_groups(path) -> dict[str, str]:
    """``{subject: group}`` from a groups table, in the table's order.

    Raises
    ------
    CohortError
        The file cannot be read, lacks a ``subject`` or ``group`` column, names a
        subject twice, or has an empty subject or group (the message names the
        file and the line).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise CohortError(f"groups table {path}: cannot be read ({exc.strerror or exc})") from None
    reader = csv.reader(io.StringIO(text))
    header = next(reader, None)
    if header is None:
        raise CohortError(f"groups table {path}: the file is empty")
    columns = {name.strip().lower(): i for i, name in enumerate(header)}
    missing = [c for c in ("subject", "group") if c not in columns]
    if missing:
        raise CohortError(
            f"groups table {path}: missing column(s) {missing}; expected a header "
            f"'subject,group', got {header}"
        )
    groups: dict[str, str] = {}
    for line, row in enumerate(reader, start=2):
        if not any(cell.strip() for cell in row):
            continue
        cells = [
            row[columns[c]].strip() if columns[c] < len(row) else "" for c in ("subject", "group")
        ]
        subject, group = cells
        if not subject or not group:
            raise CohortError(f"groups table {path}, line {line}: empty subject or group")
        if subject in groups:
            raise CohortError(f"groups table {path}, line {line}: subject {subject!r} listed twice")
        groups[subject] = group
    if not groups:
        raise CohortError(f"groups table {path}: no subject listed")
    return groups
