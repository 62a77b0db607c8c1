"""Mesh files of a study's shapes and area strains, to open in ParaView or any VTK viewer.

For every subject and every ``alpha^2`` the study computes, with and without
residuals, the midpoint ``M``, the reflected end-systole ``s_M(S')`` and the
pole-ladder transport ``T' = s_T(s_M(S'))`` (Algorithm 1), and the ``T'`` of its
third transport method: the fanning scheme (LDDMM) or the SVF pole ladder by
conjugation (SVF). :func:`write_subject_meshes` writes them through meshio
(``.vtu`` by default, legacy ``.vtk`` on request) with per-vertex point data::

    meshes/
        atlas.vtu                              T, written once (no point data)
        <subject>/
            S.vtu, S_prime.vtu                 the subject's S and S'
            alpha2_<a>/
                pole_ladder_residual_M.vtu            M
                pole_ladder_residual_sM_Sprime.vtu    s_M(S')
                pole_ladder_residual_Tprime.vtu       T'
                pole_ladder_no_residual_{M,sM_Sprime,Tprime}.vtu
                fanning_Tprime.vtu                    T' of the fanning scheme (LDDMM)
                svf_conjugation_Tprime.vtu            T' of the SVF conjugation (SVF)

Point data (every shape is in vertex correspondence with the atlas, so a
vertex's value is attached to the same material point on every mesh). The
atlas is shared by all subjects and carries none; every mesh of a subject
carries ``las_subject``:

``las_subject``
    Local area strain from ``S`` to ``S'`` (the subject's own motion). On the
    atlas-side meshes (``M``, ``s_M(S')``, ``T'``) it is shown through the vertex
    correspondence: the value at vertex ``i`` is the strain of the subject at
    its vertex ``i``.
``las_transported``
    Local area strain from ``T`` to ``T'`` for the file's transport method.
``las_difference``
    ``las_transported - las_subject``; its L2 norm over the vertices is the ASE.
``displacement``
    On ``T'``: ``T' - T``; on ``S`` and ``S'``: ``S' - S`` (vectors, for
    ParaView's *Warp By Vector*).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from ..errors import MeshFolderError
from ..files import atomic_path

__all__ = [
    "MESH_OUTPUT_FORMATS",
    "TransportShapes",
    "write_point_mesh",
    "write_subject_meshes",
    "alpha_folder",
]

#: Extensions of the mesh files a study can write.
MESH_OUTPUT_FORMATS = (".vtu", ".vtk")


@dataclass(frozen=True)
class TransportShapes:
    """The shapes of one transport method at one ``alpha^2``, each ``(k, 3)``.

    Attributes
    ----------
    method : str
        The transport method (``"pole_ladder_residual"``, ``"fanning"``, ...).
    transported : array
        ``T'``.
    midpoint, reflected : array or None
        ``M`` and ``s_M(S')`` of a pole ladder (None for the other methods).
    """

    method: str
    transported: np.ndarray
    midpoint: np.ndarray | None = None
    reflected: np.ndarray | None = None


def write_point_mesh(path, vertices, faces, point_data: dict | None = None) -> Path:
    """Write a triangle mesh with point data through meshio, atomically.

    Parameters
    ----------
    path : str or Path
        Target file; its extension (one of :data:`MESH_OUTPUT_FORMATS`) gives the
        format: VTK XML unstructured grid (``.vtu``, zlib-compressed) or legacy
        VTK (``.vtk``, binary).
    vertices : array_like, shape (k, 3)
    faces : array_like of int, shape (f, 3)
    point_data : dict of str to array_like, optional
        Arrays of shape ``(k,)`` (scalars) or ``(k, 3)`` (vectors).

    Returns
    -------
    Path
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in MESH_OUTPUT_FORMATS:
        raise MeshFolderError(f"{path}: output format must be one of {MESH_OUTPUT_FORMATS}")
    v = np.asarray(vertices, dtype=np.float64)
    data = {}
    for name, values in (point_data or {}).items():
        arr = np.asarray(values, dtype=np.float64)
        if arr.shape[:1] != (len(v),):
            raise MeshFolderError(
                f"point_data[{name!r}]: expected {len(v)} values (one per vertex), got {arr.shape}"
            )
        data[name] = arr
    mesh = meshio.Mesh(v, [("triangle", np.asarray(faces, dtype=np.int64))], point_data=data)
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu" if ext == ".vtu" else "vtk", binary=True)
    return path


def alpha_folder(alpha2) -> str:
    """Name of the folder of one ``alpha^2``, e.g. ``alpha2_0.01``."""
    return f"alpha2_{float(alpha2):g}"


def write_subject_meshes(
    folder,
    subject: Any,
    atlas,
    faces,
    result: Any,
    shapes: list[TransportShapes],
    ext: str = ".vtu",
) -> list[Path]:
    """Write one subject's shapes and strain maps at one ``alpha^2`` (layout above).

    Parameters
    ----------
    folder : str or Path
        The meshes folder (``<study output>/meshes/<config>``); created if
        needed. The atlas is written there unless it already exists.
    subject : Subject
        ``name``, ``ed`` (``S``) and ``es`` (``S'``), each ``(k, 3)``.
    atlas : array_like, shape (k, 3)
        The atlas ``T``.
    faces : array_like of int, shape (f, 3)
    result : PairResult
        The pair's result: the subject's strain and each transport's strain.
    shapes : list of TransportShapes
        The shapes of each transport method of ``result``.
    ext : {".vtu", ".vtk"}

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(folder)
    atlas = np.asarray(atlas, dtype=np.float64)
    written = []
    if not (folder / f"atlas{ext}").exists():
        written.append(write_point_mesh(folder / f"atlas{ext}", atlas, faces))
    base = folder / subject.name
    las_subject = np.asarray(result.las_subject)
    motion = {"las_subject": las_subject, "displacement": subject.es - subject.ed}
    written.append(write_point_mesh(base / f"S{ext}", subject.ed, faces, motion))
    written.append(write_point_mesh(base / f"S_prime{ext}", subject.es, faces, motion))
    sub = base / alpha_folder(result.alpha2)
    for shape in shapes:
        las_t = np.asarray(result.transport(shape.method).las)
        data = {
            "las_subject": las_subject,
            "las_transported": las_t,
            "las_difference": las_t - las_subject,
        }
        moved = {"displacement": np.asarray(shape.transported) - atlas}
        path = sub / f"{shape.method}_Tprime{ext}"
        written.append(write_point_mesh(path, shape.transported, faces, {**data, **moved}))
        for label, points in (("M", shape.midpoint), ("sM_Sprime", shape.reflected)):
            if points is not None:
                path = sub / f"{shape.method}_{label}{ext}"
                written.append(write_point_mesh(path, points, faces, data))
    return written
