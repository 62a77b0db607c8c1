"""Segmentations simulated from a cohort in correspondence, for tests, benchmarks and the tutorial.

:func:`simulate_segmentations` writes what a segmentation tool would give for a
cohort whose correspondence is known: every ED and ES mesh remeshed (another
vertex count and triangulation, :func:`~ladders.study.preparation.remeshing.remesh`),
each subject moved by its own random rigid motion (one for its two frames, as
one scanner frame), chosen subjects written in metres. The correspondence can
then be checked against the cohort it came from.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from manifolds.validation import check_rng

from ..cohort import Cohort
from ..mesh_io import write_mesh
from .alignment import SimilarityTransform, random_rigid_transform
from .remeshing import remesh

__all__ = ["simulate_segmentations"]


def simulate_segmentations(
    cohort: Cohort,
    folder,
    rng: np.random.Generator,
    *,
    face_factor: float = 2.0,
    in_metres=(),
    max_angle: float = 180.0,
    max_translation: float = 50.0,
    ext: str = ".ply",
) -> dict[str, SimilarityTransform]:
    """Write the cohort's meshes as segmentations into ``folder`` (see the module).

    Parameters
    ----------
    cohort : Cohort
    folder : str or Path
        Receives ``<name>_ed<ext>``, ``<name>_es<ext>`` and ``atlas.vtk``.
    rng : numpy.random.Generator
    face_factor : float, default 2.0
        Each mesh gets about ``face_factor`` times the atlas's face count.
    in_metres : iterable of str
        Subjects written in metres (the cohort is in mm).
    max_angle, max_translation : float
        Range of the random rigid motions (degrees, mm).
    ext : str

    Returns
    -------
    dict
        Per subject, the rigid motion applied (before the change of unit).
    """
    check_rng(rng)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    n_faces = max(4, int(round(face_factor * len(cohort.faces))))
    metres = set(in_metres)
    motions = {}
    for s in cohort.subjects:
        motions[s.name] = random_rigid_transform(rng, max_angle, max_translation)
        unit = 1e-3 if s.name in metres else 1.0
        for phase, vertices in (("ed", s.ed), ("es", s.es)):
            v, f = remesh(vertices, cohort.faces, n_faces)
            write_mesh(folder / f"{s.name}_{phase}{ext}", motions[s.name].apply(v) * unit, f)
    write_mesh(folder / "atlas.vtk", cohort.atlas, cohort.faces)
    return motions
