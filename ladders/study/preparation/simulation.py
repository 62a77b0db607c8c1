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
import trimesh

from manifolds.validation import check_rng

from ..cohort import Cohort, Subject
from ..meshes.mesh_io import write_mesh
from .alignment import SimilarityTransform, procrustes, random_rigid_transform
from .remeshing import remesh

__all__ = [
    "simulate_segmentations",
    "recovery_errors",
    "procrustes_aligned",
    "vertex_error_components",
]


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
    landmarks: bool = False,
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

    landmarks : bool, default False
        Also write ``landmarks.csv`` (each subject's apex, base-plane centre and septal
        point, moved and in its file's unit, and the atlas's), which fixes each
        subject's turn about the long axis in ``correspond_cohort``.

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
    if landmarks:
        from .landmarks import LANDMARKS_FILE, write_landmarks
        from .synthetic_landmarks import synthetic_landmarks

        table = {"atlas": synthetic_landmarks(cohort.atlas)}
        for s in cohort.subjects:
            moved = synthetic_landmarks(s.ed).transformed(motions[s.name])
            table[s.name] = moved.scaled(1e-3 if s.name in metres else 1.0)
        write_landmarks(folder / LANDMARKS_FILE, table)
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
    Each error is also split along the model mesh's vertex normals: the normal part
    is what a surface data term sees, the tangential part (vertices sliding along the
    surface) is not determined by the surfaces; its circumferential share (about the
    long axis) is where a twist shows.

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
        ``{subject: {"ed": rms, "es": rms, "rotation": degrees, "ed_normal": rms,
        "ed_tangential": rms, "ed_circumferential": rms, ...}}`` (the same three for
        ``"es"``), in the cohort's unit.
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
        row = {"rotation": float(np.degrees(beta))}
        for phase, truth, found in (("ed", truth_ed, c.ed), ("es", truth_es, c.es)):
            parts = vertex_error_components(fit.apply(truth), found, cohort.faces)
            row[phase] = parts.pop("total")
            row.update({f"{phase}_{key}": value for key, value in parts.items()})
        out[s.name] = row
    return out


def vertex_error_components(truth, found, faces) -> dict:
    """Per-vertex RMS of ``found - truth``, whole and split along the surface of ``truth``.

    Parameters
    ----------
    truth, found : arrays, shape ``(k, 3)``
        The true vertices and the recovered ones (same order).
    faces : array, shape ``(f, 3)``
        Triangles of ``truth`` (its vertex normals split the error).

    Returns
    -------
    dict
        ``total``; ``normal`` (along the vertex normals: what a surface data term
        sees); ``tangential`` (sliding along the surface, not determined by the
        surfaces); ``circumferential`` (the tangential part about the ``z`` axis
        through the centroid, where a twist about the long axis shows). ``total^2 =
        normal^2 + tangential^2``.
    """
    truth = np.asarray(truth, dtype=float)
    err = np.asarray(found, dtype=float) - truth
    normals = np.asarray(trimesh.Trimesh(truth, faces, process=False).vertex_normals)
    along = (err * normals).sum(1)
    tangential = err - along[:, None] * normals
    centre = truth.mean(axis=0)
    circ = np.stack([centre[1] - truth[:, 1], truth[:, 0] - centre[0], np.zeros(len(truth))], 1)
    circ /= np.maximum(np.linalg.norm(circ, axis=1, keepdims=True), 1e-12)

    def rms(v):
        return float(np.sqrt((np.asarray(v) ** 2).reshape(len(truth), -1).sum(1).mean()))

    return {
        "total": rms(err),
        "normal": rms(along),
        "tangential": rms(tangential),
        "circumferential": rms((tangential * circ).sum(1)),
    }


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
