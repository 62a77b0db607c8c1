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
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..files import file_sha256
from ..meshes import MESH_EXTENSIONS, read_mesh
from .atlas import AtlasResult, estimate_atlas, meshes_correspond
from .atlas_record import atlas_fingerprint, atlas_record, reusable_atlas, write_atlas
from .atlas_subset import choose_atlas_subset, shape_descriptor
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
    """What :func:`build_atlas` did: the estimate, the record and where both are; ``reused``:
    a finished atlas of the same key was there (``result`` then read back: its vertices,
    faces, convergence and history, no transforms)."""

    result: AtlasResult
    record: dict
    atlas_path: Path
    record_path: Path
    inputs: AtlasInputs
    term: str
    start: str
    reused: bool = False


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
    subset: int | None = 50,
    subset_rule: str = "stratified",
    subset_seed: int = 0,
    jobs: int = 1,
    resume: bool = True,
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
        As :func:`resolve_atlas_start` and :func:`atlas_term`; with a subset, the default
        start is the subset's first subject, and a subject outside it may be named.
    tol, max_iter, progress
        As :func:`estimate_atlas` (``progress(it, objective, norm)`` per iteration).
    units, allow_scale
        As :func:`read_atlas_inputs`.
    inputs : AtlasInputs, optional
        The inputs, already read (``meshes``, ``units`` and ``allow_scale`` then unused).
    landmarks : str, Path, dict or False, optional
        A landmark table (:mod:`.landmarks`) or ``{subject: Landmarks}``; by default
        ``landmarks.csv`` of the folder when there is one; False: none.
    subset : int or None, default 50
        Estimate the atlas from this many subjects (every subject when there are at most
        that many), chosen by ``subset_rule`` (:func:`~.atlas_subset.choose_atlas_subset`
        on every mesh's :func:`~.atlas_subset.shape_descriptor`), each weighted by the
        share of the cohort it stands for; the record names them. None: every subject.
        (The default: ``docs/preparation.md``, "The atlas at population scale".)
    subset_rule : {"stratified", "random"}
    subset_seed : int, default 0
    jobs : int, default 1
        Registrations of an iteration in parallel (:func:`estimate_atlas`).
    resume : bool, default True
        Reuse the atlas at ``output`` when its record has this run's key (the same
        inputs, settings, start, term, tolerance and subset) and it finished.

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
    chosen = _subset(inputs, subset, subset_rule, subset_seed)
    if start is None and chosen is not None:
        start = inputs.names[chosen.indices[0]]
    initial, label = resolve_atlas_start(inputs, start)
    surface, name = atlas_term(inputs, initial, term)
    settings = settings or CorrespondenceSettings()
    if name != "landmarks":
        settings = settings.replace(data_term=name)
    rows, start_lm = _landmark_list(landmarks, meshes, inputs)
    if rows is not None and isinstance(initial, tuple) and start_lm is None:
        sidecar = atlas_landmarks_path(start) if start else None
        if sidecar is None or not sidecar.is_file():
            raise LandmarkError(
                f"landmarks: the start {start} has none: add its row 'atlas' to the table or "
                f"write them to {sidecar}"
            )
        start_lm = read_landmarks(sidecar).get("atlas")
    hashes = {str(p.resolve()): file_sha256(p) for p in inputs.files}
    rule = None if chosen is None else {"rule": chosen.rule, "n": subset, "seed": chosen.seed}
    fingerprint = atlas_fingerprint(
        inputs, hashes, settings, term=name, start=label, tol=tol, max_iter=max_iter,
        subset=rule, landmarks=None if rows is None else [*rows, start_lm],
    )  # fmt: skip
    faces = initial[1] if isinstance(initial, tuple) else inputs.meshes[
        0 if initial == "mean" else initial
    ][1]  # fmt: skip
    stored = reusable_atlas(output, fingerprint["key"]) if resume else None
    if stored is not None:
        return _reused(stored, output, inputs, name, label)
    used, weights, initial, start_lm = _restrict(inputs, chosen, initial, rows, start_lm)
    subset_record = None if chosen is None else {
        **rule, "from": len(inputs.names), "descriptor": "principal RMS extents (mm)",
        "weights": {inputs.names[i]: float(w) for i, w in zip(chosen.indices, chosen.weights)},
    }  # fmt: skip
    seen: dict = {"objectives": [], "gradient_norms": []}

    def report(it, objective, norm):
        seen["objectives"].append(objective)
        seen["gradient_norms"].append(norm)
        if progress is not None:
            progress(it, objective, norm)

    def checkpoint(it, vertices):
        seen.update(n_iter=it, vertices=vertices)

    def record_of(result: dict, interrupted: bool) -> dict:
        result = {**result, "term": name, "subjects": [inputs.names[i] for i in used]}
        return atlas_record(output, inputs, settings, label, result, tol, max_iter,
                            interrupted, input_hashes=hashes, key=fingerprint["key"],
                            subset=subset_record)  # fmt: skip

    try:
        res = estimate_atlas(
            [inputs.meshes[i] for i in used], settings, initial=initial, tol=tol,
            max_iter=max_iter, progress=report, surface_term=surface, checkpoint=checkpoint,
            landmarks=None if rows is None else [rows[i] for i in used],
            start_landmarks=start_lm, weights=weights, jobs=jobs,
        )  # fmt: skip
    except KeyboardInterrupt:
        if seen.get("n_iter", 0) < 1:
            raise
        write_atlas(output, seen["vertices"], faces, record_of(seen, True))
        raise AtlasInterrupted(
            f"the iterate of iteration {seen['n_iter']} was written to {output}; continue "
            f"with --start {output}"
        ) from None
    record = record_of(vars(res), False)
    if res.landmarks is not None:
        record["landmarks"] = str(
            write_landmarks(atlas_landmarks_path(output), {"atlas": res.landmarks})
        )
    path = write_atlas(output, res.vertices, res.faces, record)
    return AtlasRun(res, record, output, path, inputs, name, label)


def _subset(inputs: AtlasInputs, n, rule, seed):
    """The subset of ``inputs`` to estimate the atlas from, or None (every subject)."""
    if n is None:
        return None
    descriptors = np.array([shape_descriptor(v, f) for v, f in inputs.meshes])
    try:
        return choose_atlas_subset(descriptors, n, rule, seed)
    except ValueError as exc:
        raise ValueError(f"subset: {str(exc).removeprefix('choose_atlas_subset: ')}") from None


def _restrict(inputs: AtlasInputs, chosen, initial, rows, start_lm):
    """The subjects used (indices), their weights, and the start and its landmarks in
    terms of them: a start subject outside the subset is given as its mesh."""
    if chosen is None:
        return list(range(len(inputs.names))), None, initial, start_lm
    used = [int(i) for i in chosen.indices]
    if isinstance(initial, int | np.integer) and not isinstance(initial, bool):
        if initial in used:
            initial = used.index(initial)
        else:
            start_lm = None if rows is None else rows[initial]
            initial = inputs.meshes[initial]
    return used, chosen.weights, initial, start_lm


def _reused(record: dict, output: Path, inputs: AtlasInputs, term: str, label: str) -> AtlasRun:
    vertices, faces = read_mesh(output)
    lm = None
    if record.get("landmarks") and Path(record["landmarks"]).is_file():
        lm = read_landmarks(record["landmarks"]).get("atlas")
    result = AtlasResult(
        vertices, faces, bool(record["converged"]), int(record["n_iter"]),
        list(record["objectives"]), list(record.get("gradient_norms", [])), [],
        term == "landmarks", record.get("message", ""), lm, 0,
    )  # fmt: skip
    return AtlasRun(result, record, output, output.with_suffix(".json"), inputs, term, label,
                    reused=True)  # fmt: skip
