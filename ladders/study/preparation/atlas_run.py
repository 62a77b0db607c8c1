"""The atlas of a folder of segmentations, written with its record: what ``symladders atlas`` runs.

:func:`build_atlas` reads the end-diastolic meshes of a folder in one unit
(:func:`~ladders.study.preparation.read_atlas_inputs`), resolves the start (a
subject, the mean shape or a mesh file) and the data term (landmarks when the
meshes correspond, a surface term otherwise), runs
:func:`~ladders.study.preparation.estimate_atlas` and writes the atlas and, next
to it, ``<name>.json``: convergence, objectives, data term, start, units,
settings and the input files' SHA-256. Interrupted, it writes the last iterate
and its record (``"interrupted": true``) before it stops, and raises
:class:`AtlasInterrupted`, which says how to continue. With a landmark table
(``landmarks.csv`` in the folder, or one given), every subject's turn about the
long axis follows its landmarks, and the atlas's own are written next to it as
``<name>_landmarks.csv`` (row ``atlas``), where ``symladders correspond`` finds them.
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..files import atomic_write_text, file_sha256
from ..meshes import MESH_EXTENSIONS, read_mesh, write_mesh
from .atlas import AtlasResult, estimate_atlas, meshes_correspond
from .cohort_units import AtlasInputs, read_atlas_inputs
from .correspondence_settings import CorrespondenceSettings
from .landmarks import (
    LANDMARKS_FILE,
    LandmarkError,
    atlas_landmarks_path,
    read_landmarks,
    refuse_unknown_subjects,
    write_landmarks,
)

__all__ = [
    "AtlasRun",
    "AtlasInterrupted",
    "build_atlas",
    "resolve_atlas_start",
    "atlas_term",
]


def _landmark_list(landmarks, meshes, inputs: AtlasInputs):
    """The subjects' landmarks in the meshes' unit, in ``inputs.names`` order, or None."""
    if landmarks is False:
        return None, None
    if landmarks is None:
        if not isinstance(meshes, str | Path) or not (Path(meshes) / LANDMARKS_FILE).is_file():
            return None, None
        landmarks = Path(meshes) / LANDMARKS_FILE
    table = landmarks if isinstance(landmarks, dict) else read_landmarks(landmarks)
    refuse_unknown_subjects(table, [*inputs.names, *inputs.skipped], "the table given")
    table = dict(table)
    missing = [n for n in inputs.names if n not in table]
    if missing:
        raise LandmarkError(f"landmarks: no row for subject(s) {missing} in {landmarks}")
    factors = inputs.units.factors if inputs.units is not None else {}
    rows = [table[n].scaled(factors.get(n, 1.0)) for n in inputs.names]
    return rows, table.get("atlas")


TERMS = ("auto", "landmarks", "varifold", "current")


class AtlasInterrupted(KeyboardInterrupt):
    """The atlas was interrupted; :attr:`message` says what was kept and how to continue."""

    def __init__(self, message: str):
        super().__init__(message)
        self.message = message


@dataclass
class AtlasRun:
    """What :func:`build_atlas` did: the estimate, the record and where both are."""

    result: AtlasResult
    record: dict
    atlas_path: Path
    record_path: Path
    inputs: AtlasInputs
    term: str
    start: str


def resolve_atlas_start(inputs: AtlasInputs, start: str | None):
    """``(initial, label)`` of :func:`estimate_atlas` for ``start``.

    ``start`` is None (the first subject), ``"mean"`` (meshes in correspondence), a
    subject's name or a mesh file. Raises ``ValueError`` starting with ``start:``.
    """
    if start is None:
        return 0, inputs.names[0]
    if start == "mean":
        if not meshes_correspond(inputs.meshes):
            raise ValueError(
                "start mean: the mean shape needs meshes in correspondence (one vertex count "
                "and triangulation); name a subject instead"
            )
        return "mean", "mean"
    if start in inputs.names:
        return inputs.names.index(start), start
    if Path(start).suffix.lower() in MESH_EXTENSIONS and Path(start).is_file():
        try:
            return read_mesh(start), str(Path(start).resolve())
        except (ValueError, OSError) as exc:
            raise ValueError(f"start: {exc}") from None
    why = f"its ED mesh was not read ({inputs.skipped[start]})" if start in inputs.skipped else (
        "no subject of that name and no mesh file"
    )  # fmt: skip
    close = difflib.get_close_matches(start, inputs.names, n=1)
    hint = (
        f"; did you mean {close[0]!r}?" if close else f" (subjects: {', '.join(inputs.names[:5])}"
    )
    hint += "" if close else (", ...)" if len(inputs.names) > 5 else ")")
    raise ValueError(f"start {start!r}: {why}{hint}")


def atlas_term(inputs: AtlasInputs, initial, term: str = "auto") -> tuple[bool | None, str]:
    """``(surface_term, name)``: the argument of :func:`estimate_atlas` and the term used.

    ``term`` is one of :data:`TERMS`; ``"auto"`` is landmarks when the meshes (and the
    start) share one vertex count and triangulation, a varifold otherwise. Raises
    ``ValueError`` starting with ``term`` for landmarks on meshes that do not correspond.
    """
    if term not in TERMS:
        raise ValueError(f"term: expected one of {list(TERMS)}, got {term!r}")
    start = [initial] if isinstance(initial, tuple) else []
    corresponding = meshes_correspond(inputs.meshes + start)
    if term == "landmarks" and not corresponding:
        raise ValueError(
            "term landmarks: the meshes (and the start) do not share one vertex count and "
            "triangulation; use the auto or varifold term"
        )
    if term == "landmarks" or (term == "auto" and corresponding):
        return (False if term == "landmarks" else None), "landmarks"
    return (None if term == "auto" else True), ("varifold" if term == "auto" else term)


def _record(output, inputs, settings, label, result, tol, max_iter, interrupted) -> dict:
    return {
        "atlas": str(Path(output).resolve()),
        "converged": bool(result.get("converged", False)) and not interrupted,
        "interrupted": interrupted,
        "n_iter": result["n_iter"],
        "objectives": result["objectives"],
        "gradient_norms": result.get("gradient_norms", []),
        "term": result["term"],
        "start": label,
        "tol": tol,
        "max_iter": max_iter,
        "subjects": inputs.names,
        "skipped": inputs.skipped,
        "units": {**inputs.units.as_dict(), "reference": inputs.reference},
        "settings": settings.as_dict(),
        "input_files": {str(p.resolve()): file_sha256(p) for p in inputs.files},
        "message": result.get("message", ""),
    }


def _write(output: Path, vertices, faces, record: dict) -> Path:
    output.parent.mkdir(parents=True, exist_ok=True)
    write_mesh(output, vertices, faces, atomic=True)
    path = output.with_suffix(".json")
    atomic_write_text(path, json.dumps(record, indent=1, default=str))
    return path


def build_atlas(
    meshes,
    output,
    settings: CorrespondenceSettings | None = None,
    *,
    start: str | None = None,
    term: str = "auto",
    tol: float = 0.1,
    max_iter: int = 10,
    units: str | None = None,
    allow_scale: bool = False,
    progress: Callable | None = None,
    inputs: AtlasInputs | None = None,
    landmarks=None,
) -> AtlasRun:
    """Estimate the atlas of the ED meshes of the folder ``meshes`` and write it to ``output``.

    Parameters
    ----------
    meshes : path
        A folder in the study's layout (its ED meshes are used).
    output : path
        The atlas file (format from the extension); the record goes next to it.
    settings : CorrespondenceSettings, optional
        Registration settings; with a surface term, its data term is the one resolved.
    start, term
        As :func:`resolve_atlas_start` and :func:`atlas_term`.
    tol, max_iter, progress
        As :func:`estimate_atlas` (``progress(it, objective, norm)`` per iteration).
    units, allow_scale
        As :func:`read_atlas_inputs`.
    inputs : AtlasInputs, optional
        The inputs, already read (``meshes``, ``units`` and ``allow_scale`` then unused).
    landmarks : str, Path, dict or False, optional
        A landmark table (:mod:`.landmarks`) or ``{subject: Landmarks}``; by default
        ``landmarks.csv`` of the folder when there is one; False: none.

    Raises
    ------
    ValueError
        A start, term or input that cannot be used (the message names which).
    UnitsError
        Meshes in several units (see :func:`read_atlas_inputs`).
    AtlasInterrupted
        On Ctrl-C, once the last iterate and its record are written.
    """
    output = Path(output)
    if inputs is None:
        inputs = read_atlas_inputs(meshes, units=units, allow_scale=allow_scale)
    initial, label = resolve_atlas_start(inputs, start)
    surface, name = atlas_term(inputs, initial, term)
    settings = settings or CorrespondenceSettings()
    if name != "landmarks":
        settings = settings.replace(data_term=name)
    seen: dict = {"objectives": [], "gradient_norms": []}

    def report(it, objective, norm):
        seen["objectives"].append(objective)
        seen["gradient_norms"].append(norm)
        if progress is not None:
            progress(it, objective, norm)

    def checkpoint(it, vertices):
        seen.update(n_iter=it, vertices=vertices)

    rows, start_lm = _landmark_list(landmarks, meshes, inputs)
    if rows is not None and isinstance(initial, tuple) and start_lm is None:
        sidecar = atlas_landmarks_path(start) if start else None
        if sidecar is None or not sidecar.is_file():
            raise LandmarkError(
                f"landmarks: the start {start} has none: add its row 'atlas' to the table or "
                f"write them to {sidecar}"
            )
        start_lm = read_landmarks(sidecar).get("atlas")
    try:
        res = estimate_atlas(
            inputs.meshes, settings, initial=initial, tol=tol, max_iter=max_iter,
            progress=report, surface_term=surface, checkpoint=checkpoint, landmarks=rows,
            start_landmarks=start_lm,
        )  # fmt: skip
    except KeyboardInterrupt:
        if seen.get("n_iter", 0) < 1:
            raise
        faces = initial[1] if isinstance(initial, tuple) else inputs.meshes[
            0 if initial == "mean" else initial
        ][1]  # fmt: skip
        result = {**seen, "term": name}
        record = _record(output, inputs, settings, label, result, tol, max_iter, True)
        _write(output, seen["vertices"], faces, record)
        raise AtlasInterrupted(
            f"the iterate of iteration {seen['n_iter']} was written to {output}; continue "
            f"with --start {output}"
        ) from None
    record = _record(output, inputs, settings, label, {**vars(res), "term": name}, tol,
                     max_iter, False)  # fmt: skip
    if res.landmarks is not None:
        record["landmarks"] = str(
            write_landmarks(atlas_landmarks_path(output), {"atlas": res.landmarks})
        )
    path = _write(output, res.vertices, res.faces, record)
    return AtlasRun(res, record, output, path, inputs, name, label)
