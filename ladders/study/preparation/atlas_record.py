"""The record written next to an atlas, its key, and the reuse of a finished atlas.

:func:`build_atlas <.atlas_run.build_atlas>` writes ``<name>.json`` next to the atlas:
convergence, objectives, data term, start, units, settings, the subjects it was
estimated from (and the subset rule that chose them), the input files' SHA-256 and a
``key``: the digest of everything the atlas depends on (:func:`atlas_fingerprint`:
the registration settings' key, the data term, the start, ``tol``, ``max_iter``, the
subset rule, every input file's content, the units and the landmarks). A rerun whose
key is that of a finished atlas (not an interrupted one) whose file is there reuses it
(:func:`reusable_atlas`) instead of estimating it again; the number of worker
processes is not part of the key (it does not change the atlas).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from ..files import atomic_write_text, file_sha256
from ..meshes import write_mesh

__all__ = ["atlas_fingerprint", "atlas_record", "reusable_atlas", "write_atlas"]


def atlas_fingerprint(inputs, input_hashes: dict, settings, *, term, start, tol, max_iter,
                      subset, landmarks) -> dict:  # fmt: skip
    """What the atlas depends on, JSON-ready, with its digest under ``"key"``.

    ``start`` is the start's label (a subject, ``"mean"``) or a mesh file, hashed;
    ``subset`` the rule's ``{"rule", "n", "seed"}`` or None; ``landmarks`` the subjects'
    (and the start's) :class:`~.landmarks.Landmarks` or None.
    """
    start_id = start
    if start not in inputs.names and start != "mean" and Path(start).is_file():
        start_id = file_sha256(Path(start))
    out = {
        "settings": settings.key(),
        "term": term,
        "start": start_id,
        "tol": float(tol),
        "max_iter": int(max_iter),
        "subset": subset,
        "inputs": {n: input_hashes[str(Path(f).resolve())] for n, f in
                   zip(inputs.names, inputs.files)},  # fmt: skip
        "units": inputs.units.as_dict() if inputs.units is not None else None,
        "landmarks": None if landmarks is None else [
            None if lm is None else lm.as_array().round(9).tolist() for lm in landmarks
        ],
    }  # fmt: skip
    text = json.dumps(out, sort_keys=True, default=repr)
    return {**out, "key": hashlib.sha256(text.encode()).hexdigest()[:16]}


def atlas_record(output, inputs, settings, label, result, tol, max_iter, interrupted, *,
                 input_hashes: dict, key: str, subset: dict | None) -> dict:  # fmt: skip
    """The JSON record of an atlas (``result``: the estimate's fields as a dict)."""
    used = result.get("subjects", inputs.names)
    return {
        "atlas": str(Path(output).resolve()),
        "key": key,
        "converged": bool(result.get("converged", False)) and not interrupted,
        "interrupted": interrupted,
        "n_iter": result["n_iter"],
        "objectives": result["objectives"],
        "gradient_norms": result.get("gradient_norms", []),
        "n_registrations": result.get("n_registrations"),
        "cpu_seconds": result.get("cpu_seconds"),
        "moves": result.get("moves"),
        "term": result["term"],
        "start": label,
        "tol": tol,
        "max_iter": max_iter,
        "subjects": list(used),
        "subset": subset,
        "skipped": inputs.skipped,
        "units": {**inputs.units.as_dict(), "reference": inputs.reference},
        "settings": settings.as_dict(),
        "input_files": input_hashes,
        "message": result.get("message", ""),
    }


def write_atlas(output: Path, vertices, faces, record: dict) -> Path:
    """Write the atlas (atomically) and its record next to it; the record's path."""
    output.parent.mkdir(parents=True, exist_ok=True)
    write_mesh(output, vertices, faces, atomic=True)
    path = output.with_suffix(".json")
    atomic_write_text(path, json.dumps(record, indent=1, default=str))
    return path


def reusable_atlas(output: Path, key: str) -> dict | None:
    """The record of the finished atlas at ``output`` when it has ``key``, else None."""
    try:
        record = json.loads(Path(output).with_suffix(".json").read_text())
    except (OSError, ValueError):
        return None
    done = record.get("key") == key and record.get("interrupted") is False
    return record if done and Path(output).is_file() else None
