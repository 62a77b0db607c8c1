"""Segmentations simulated from a cohort in correspondence, for tests, benchmarks and the tutorial.

:func:`simulate_segmentations` writes what a segmentation tool would give for a
cohort whose correspondence is known: every ED and ES mesh remeshed (another
vertex count and triangulation, :func:`~ladders.study.preparation.remeshing.remesh`),
each subject moved by its own random rigid motion (one for its two frames, as
one scanner frame), chosen subjects written in metres. The correspondence can
then be checked against the cohort it came from: :func:`recovery_errors`
(vertices) and :func:`procrustes_aligned` (the frame of the reference study).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from manifolds.validation import check_rng

from ..cohort import Cohort, Subject
from ..meshes.mesh_io import write_mesh
from .alignment import SimilarityTransform, procrustes, random_rigid_transform
from .remeshing import remesh

__all__ = ["simulate_segmentations", "recovery_errors", "procrustes_aligned"]


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


def _rotation_about_z(beta: float) -> np.ndarray:
    c, s = np.cos(beta), np.sin(beta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def recovery_errors(cohort: Cohort, corresponded: Cohort, transforms: dict, motions: dict) -> dict:
    """Per-vertex RMS distance of corresponded meshes to the synthetic model's, per subject.

    A subject's rotation about the long axis of the built-in (axisymmetric) atlas
    is not determined by its surface: the model's shapes are rotated by the one the
    pipeline chose (``transforms[name] o motions[name]`` about ``z``), evaluated on
    the atlas's grid, and fitted rigidly (on ED, applied to ES) to the corresponded pair.

    Parameters
    ----------
    cohort : Cohort
        The synthetic cohort the segmentations were made from (with ``parameters``).
    corresponded : Cohort
        Its correspondence (same subjects).
    transforms, motions : dict of SimilarityTransform
        Per subject, the recorded transform and the motion applied by
        :func:`simulate_segmentations`.

    Returns
    -------
    dict
        ``{subject: {"ed": rms, "es": rms, "rotation": degrees}}``.
    """
    from ..cohort.synthetic_lv import SyntheticLVModel, grid_shape, lv_grid, lv_shapes

    theta, phi, _ = lv_grid(*grid_shape(len(cohort.atlas)), SyntheticLVModel())
    by_name = {s.name: s for s in corresponded.subjects}
    out = {}
    for s in cohort.subjects:
        total = transforms[s.name].compose(motions[s.name])
        beta = float(np.arctan2(total.rotation[1, 0], total.rotation[0, 0]))
        rz = _rotation_about_z(beta)
        truth_ed, truth_es = (x @ rz.T for x in lv_shapes(s.parameters, theta, phi - beta))
        c = by_name[s.name]
        fit = procrustes(truth_ed, c.ed)
        rms = [float(np.sqrt(((fit.apply(t) - x) ** 2).sum(1).mean()))
               for t, x in ((truth_ed, c.ed), (truth_es, c.es))]  # fmt: skip
        out[s.name] = {"ed": rms[0], "es": rms[1], "rotation": float(np.degrees(beta))}
    return out


def procrustes_aligned(cohort: Cohort) -> list[Subject]:
    """The cohort's subjects moved by the rigid Procrustes fit of their ED onto the atlas.

    The frame :func:`~ladders.study.preparation.correspondence.correspond_subject`
    puts corresponded meshes in: the reference for a study on them.
    """
    out = []
    for s in cohort.subjects:
        fit = procrustes(s.ed, cohort.atlas)
        out.append(Subject(s.name, fit.apply(s.ed), fit.apply(s.es)))
    return out
