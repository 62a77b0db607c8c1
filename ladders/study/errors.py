"""Errors of the study application: an inconsistent cohort, an unreadable mesh."""

from __future__ import annotations

__all__ = ["CohortError", "MeshFolderError", "MissingAtlasError"]


class CohortError(ValueError):
    """Inconsistent cohort: shapes, faces or vertex counts do not correspond."""


class MeshFolderError(CohortError):
    """A mesh file or a cohort folder cannot be read or does not correspond."""


class MissingAtlasError(MeshFolderError):
    """No atlas was given and none was found; the message says how to name one.

    Parameters
    ----------
    problem : str
        What is missing and where, e.g. ``"meshes: no atlas file 'atlas.<ext>'"``.
    """

    def __init__(self, problem: str):
        self.problem = problem
        super().__init__(self.with_hint("atlas=PATH"))

    def with_hint(self, spelling: str) -> str:
        """The message with the way to name an atlas spelled ``spelling`` (e.g. a flag)."""
        return f"{self.problem}; name one with {spelling}"
