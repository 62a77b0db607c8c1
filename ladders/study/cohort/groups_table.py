"""The groups table: which group each subject belongs to (``subject,group`` CSV).

Written next to the meshes by ``symladders cohort`` and read by ``symladders
analyze --groups``. Columns ``subject`` and ``group`` (any order and letter case;
no other column: it would be ignored); one row per subject.
"""

from __future__ import annotations

import csv
import io

from ladders.tables import Column, TableDict, read_table

from ..errors import CohortError

__all__ = ["read_groups", "groups_csv", "GROUPS_COLUMNS"]

#: The columns of a groups table.
GROUPS_COLUMNS = (Column("subject"), Column("group"))


def groups_csv(groups: dict[str, str]) -> str:
    """The CSV text of ``{subject: group}``, in the dictionary's order."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["subject", "group"])
    for subject, group in groups.items():
        writer.writerow([subject, group])
    return out.getvalue()


def read_groups(path) -> dict[str, str]:
    """``{subject: group}`` from a groups table, in the table's order (a
    :class:`~ladders.tables.TableDict`: a later check names the line of a subject).

    Raises
    ------
    CohortError
        The file cannot be read, lacks a ``subject`` or ``group`` column, has another
        column (it would be ignored: a design table goes to ``--design``), names a
        subject twice, or has an empty subject or group (the message names the file,
        the line and the column; :func:`ladders.tables.read_table`).
    """
    table = read_table(path, GROUPS_COLUMNS, what="groups table", key=("subject",),
                       error=CohortError)  # fmt: skip
    return TableDict(((row["subject"], row["group"]) for row in table.rows), table)
