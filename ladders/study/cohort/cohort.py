"""Cohorts of corresponding surface meshes.

A :class:`Cohort` holds what the paper's Section 3 study needs: a population
atlas ``T`` and, per subject, an end-diastole shape ``S`` and an end-systole
shape ``S'``, all meshes in vertex correspondence (one shared ``faces`` array).
Cohorts come from a folder of meshes (:func:`ladders.study.cohort.read_cohort`), a
table (:func:`ladders.study.cohort.read_cohort_table`) or the synthetic generator
:func:`ladders.study.cohort.make_synthetic_cohort`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CohortError, MeshFolderError

__all__ = [
    "CohortError",
    "MeshFolderError",
    "Subject",
    "Cohort",
]


@dataclass
class Subject:
    """One subject: end-diastole ``ed`` and end-systole ``es`` vertices, each ``(k, 3)``.

    ``parameters`` holds whatever produced the shapes, e.g. the
    :class:`ladders.study.cohort.SubjectParameters` of a synthetic subject
    (``None`` for meshes read from files); ``files`` the ED and ES files the
    shapes were read from (empty for generated shapes).
    """

    name: str
    ed: np.ndarray
    es: np.ndarray
    parameters: Any = None
    files: tuple = ()


@dataclass
class Cohort:
    """Atlas and subjects sharing one triangulation.

    Attributes
    ----------
    atlas : ndarray, shape (k, 3)
        Vertices of the population atlas ``T``.
    faces : ndarray of int, shape (f, 3)
        Triangles shared by every shape of the cohort.
    subjects : list of Subject
        Per-subject end-diastole ``S`` and end-systole ``S'`` vertices, ``(k, 3)`` each.
    source : str
        Where the cohort comes from (generator call or folder).
    atlas_file : Path or None
        The file the atlas was read from (None for a generated atlas).
    """

    atlas: np.ndarray
    faces: np.ndarray
    subjects: list[Subject] = field(default_factory=list)
    source: str = ""
    atlas_file: Path | None = None

    def __post_init__(self):
        self.atlas = _vertices(self.atlas, "atlas")
        faces = np.asarray(self.faces)
        if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
            raise CohortError(f"faces: expected an integer array (f, 3), got {faces.shape}")
        k = self.atlas.shape[0]
        if faces.size and (faces.min() < 0 or faces.max() >= k):
            raise CohortError(
                f"faces: indices must lie in [0, {k}), got [{faces.min()}, {faces.max()}]"
            )
        self.faces = faces.astype(np.int64)
        for s in self.subjects:
            for label in ("ed", "es"):
                arr = _vertices(getattr(s, label), f"subject {s.name!r} {label}")
                if arr.shape != self.atlas.shape:
                    raise CohortError(
                        f"subject {s.name!r} {label}: {arr.shape[0]} vertices, atlas has {k}"
                    )
                setattr(s, label, arr)

    def __len__(self) -> int:
        return len(self.subjects)

    @property
    def n_vertices(self) -> int:
        """Number of vertices ``k`` of every shape."""
        return self.atlas.shape[0]

    @property
    def names(self) -> list[str]:
        """Subject names, in cohort order."""
        return [s.name for s in self.subjects]

    def _stacked(self, phase: str) -> np.ndarray:
        if not self.subjects:
            return np.empty((0, self.n_vertices, 3))
        return np.stack([getattr(s, phase) for s in self.subjects])

    @property
    def ed(self) -> np.ndarray:
        """End-diastole shapes stacked, shape ``(n, k, 3)``."""
        return self._stacked("ed")

    @property
    def es(self) -> np.ndarray:
        """End-systole shapes stacked, shape ``(n, k, 3)``."""
        return self._stacked("es")

    @property
    def input_files(self) -> list[Path]:
        """The files the cohort was read from: the atlas, then each subject's ED and ES."""
        atlas = [self.atlas_file] if self.atlas_file is not None else []
        return [Path(p) for p in (*atlas, *(f for s in self.subjects for f in s.files))]

    def head(self, n: int) -> Cohort:
        """The cohort restricted to its first ``n`` subjects."""
        subjects = list(self.subjects[:n])
        return Cohort(self.atlas, self.faces, subjects, self.source, self.atlas_file)


def _vertices(x, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise CohortError(f"{name}: expected vertices of shape (k, 3), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise CohortError(f"{name}: contains NaN or infinite coordinates")
    return arr
