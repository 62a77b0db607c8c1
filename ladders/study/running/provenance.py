"""Provenance of a study run: the manifest (versions, kernel backend, command line, inputs)."""

from __future__ import annotations

import json
import platform
import re
import sys
import time
from pathlib import Path

import numpy as np

from ..files import atomic_write_text, file_sha256
from .results import RegistrationCounts

__all__ = ["build_manifest", "write_manifest", "package_versions", "file_sha256"]

#: Packages whose versions are always recorded (besides the declared dependencies).
RECORDED_PACKAGES = (
    "numpy", "scipy", "autograd", "trimesh", "matplotlib", "joblib", "tqdm", "threadpoolctl",
    "numba", "llvmlite", "meshio", "dask", "distributed",
)  # fmt: skip


def package_versions() -> dict[str, str | None]:
    """Installed versions of the library, its dependencies (all extras) and :data:`RECORDED_PACKAGES`.

    A package that is not installed maps to ``None``.
    """
    from importlib import metadata

    names = set(RECORDED_PACKAGES)
    try:
        for req in metadata.requires("symladders") or []:
            names.add(re.split(r"[\s;<>=!~\[]", req, maxsplit=1)[0].lower())
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
        pass
    versions: dict[str, str | None] = {}
    for name in ["symladders", *sorted(names)]:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def _kernel_backend(outcome, config) -> list[str]:
    """Backends that ran this configuration's pairs (asked of the kernel in each worker)."""
    ran = {p.kernel_backend for r in outcome.results for p in r.pairs}
    if ran:
        return sorted(ran)
    return [config.registration.resolved_backend()]


def _counts(outcome) -> dict:
    pairs = [p for r in outcome.results for p in r.pairs]
    counts = RegistrationCounts.total(p.counts for p in pairs)
    return {
        "pairs_computed_this_run": len(outcome.computed),
        "pairs_reused": len(outcome.skipped),
        "pairs_recomputed": [
            {"subject": name, "alpha2": a2, "reason": why}
            for (name, a2), why in sorted(outcome.recomputed.items())
        ],
        "failed_pairs": [
            {"subject": f.subject, "alpha2": f.alpha2, "error": f.error} for f in outcome.failures
        ],
        "failed_subjects": outcome.n_failed_subjects,
        "wall_time_this_run_s": outcome.seconds,
        "pair_time_total_s": float(sum(p.seconds for p in pairs)),
        "registrations": counts.n_registrations,
        "non_converged_registrations": counts.non_converged,
        "optimiser_iterations": counts.n_iterations,
        "flow_evaluations": counts.n_flow_evaluations,
        "max_gradient_norm": counts.max_gradient_norm,
    }


def build_manifest(outcome, config, atlas, faces, jobs: int, data: dict, input_files: list) -> dict:
    """The manifest of a run (a JSON-ready dict).

    Records the library and dependency versions, Python, the platform, the
    kernel backend that actually ran (not the requested ``"auto"``), the
    command line, the seed (``data["seed"]`` when given), the configuration and
    its results folder, the SHA-256 of every input mesh file, counts and timings.
    """
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "versions": package_versions(),
        "command_line": list(sys.argv),
        "seed": data.get("seed"),
        "config": config.as_dict(),
        "kernel_backend_requested": config.registration.kernel_backend,
        "kernel_backend": _kernel_backend(outcome, config),
        "results_folder": f"results/{outcome.config_id}",
        "data": data,
        "input_files": {str(Path(p)): file_sha256(p) for p in input_files},
        "n_subjects": len(outcome.results),
        "n_vertices": int(np.asarray(atlas).shape[0]),
        "n_faces": int(np.asarray(faces).shape[0]),
        "jobs": jobs,
        **_counts(outcome),
        "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }


def write_manifest(outcome, config, atlas, faces, jobs, data, input_files) -> dict:
    """Write the manifest to ``manifest.json`` and into the configuration's folder."""
    manifest = build_manifest(outcome, config, atlas, faces, jobs, data, input_files)
    text = json.dumps(manifest, indent=2, default=str)
    atomic_write_text(outcome.output / "manifest.json", text)
    atomic_write_text(outcome.output / manifest["results_folder"] / "manifest.json", text)
    return manifest
