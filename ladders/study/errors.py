"""Errors of the study application: an inconsistent cohort, an unreadable mesh."""

from __future__ import annotations

__all__ = ["CohortError", "MeshFolderError"]


class CohortError(ValueError):
    """Inconsistent cohort: shapes, faces or vertex counts do not correspond."""


class MeshFolderError(CohortError):
    """A mesh file or a cohort folder cannot be read or does not correspond."""
