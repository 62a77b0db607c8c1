"""Running the study over a cohort: parallel subjects, resumable, with a manifest."""

from __future__ import annotations

import json
import platform
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .cohort import Subject
from .mesh_outputs import write_subject_meshes
from .pipeline import StudyConfig, run_subject
from .store import SubjectStore, array_digest, atomic_write_text, config_hash

__all__ = ["StudyOutcome", "run_study"]


@dataclass
class StudyOutcome:
    """What :func:`run_study` returns: per-subject results and where they are."""

    output: Path
    results: list
    computed: list
    skipped: list
    seconds: float


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("symladders")
    except Exception:  # pragma: no cover - not installed as a distribution
        return "unknown"


def _params(config: StudyConfig, atlas, faces) -> dict:
    """Everything the results depend on besides the subject's own meshes."""
    cfg = config.as_dict()
    cfg.pop("kernel_backend")  # both backends compute the same sums (tested to ~1e-11)
    return {"config": cfg, "atlas": array_digest(atlas), "faces": array_digest(faces)}


def _subject_hash(params: dict, subject: Subject) -> str:
    return config_hash({**params, "ed": array_digest(subject.ed), "es": array_digest(subject.es)})


def run_study(
    config: StudyConfig,
    atlas: np.ndarray,
    faces: np.ndarray,
    subjects: list[Subject],
    output: str | Path,
    jobs: int = 1,
    progress: bool = True,
    data_description: dict | None = None,
    meshes: bool = True,
) -> StudyOutcome:
    """Run (or resume) the study and write per-subject results and a manifest.

    Parameters
    ----------
    config : StudyConfig
    atlas : array, shape (k, 3)
        The template ``T``.
    faces : int array, shape (f, 3)
        Triangles shared by all meshes (vertex correspondence).
    subjects : list of Subject
    output : path
        Results folder; ``subjects/<name>.json`` are written atomically as
        each subject finishes, so an interrupted run loses no finished subject.
    jobs : int
        Parallel workers (joblib); ``-1`` uses all cores. Inside a
        ``joblib.parallel_config(backend="dask")`` block the subjects run on
        a Dask cluster instead.
    progress : bool
        Show a progress bar (tqdm).
    data_description : dict, optional
        Recorded in the manifest (e.g. the cohort generator's parameters).
    meshes : bool
        Write each computed subject's shapes and strain maps as ``.vtu`` files
        under ``output/meshes`` (see :mod:`ladders.study.mesh_outputs`).

    Returns
    -------
    StudyOutcome
    """
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    start = time.perf_counter()
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    params = _params(config, atlas, faces)
    stores = {s.name: SubjectStore(output, _subject_hash(params, s)) for s in subjects}
    names = [s.name for s in subjects]
    if len(set(names)) != len(names):
        raise ValueError("subjects: subject names must be unique")
    todo = [s for s in subjects if stores[s.name].load(s.name) is None]
    skipped = [s.name for s in subjects if s not in todo]

    def task(subject):
        result = run_subject(config, atlas, faces, subject, keep_shapes=meshes)
        if meshes:
            write_subject_meshes(output / "meshes", subject, atlas, faces, result)
        stores[subject.name].save(subject.name, result)  # written by the worker itself
        return subject.name

    computed = []
    if todo:
        runner = Parallel(n_jobs=jobs, return_as="generator_unordered")
        bar = tqdm(total=len(todo), desc="subjects", disable=not progress, unit="subject")
        try:
            for name in runner(delayed(task)(s) for s in todo):
                computed.append(name)
                bar.update(1)
        finally:
            bar.close()
    results = [stores[s.name].load(s.name) for s in subjects]
    missing = [s.name for s, r in zip(subjects, results, strict=True) if r is None]
    if missing:
        raise RuntimeError(f"results missing after the run for subjects {missing}")
    seconds = time.perf_counter() - start
    manifest = {
        "library_version": _version(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "config": config.as_dict(),
        "data": data_description or {},
        "n_subjects": len(subjects),
        "n_vertices": int(np.asarray(atlas).shape[0]),
        "n_faces": int(np.asarray(faces).shape[0]),
        "jobs": jobs,
        "computed_this_run": len(computed),
        "resumed_from_previous_runs": len(skipped),
        "wall_time_this_run_s": seconds,
        "subject_time_total_s": float(sum(r["seconds"] for r in results)),
        "registrations": int(
            sum(a["n_registrations"] for r in results for a in r["alpha2"].values())
        ),
        "non_converged_registrations": int(sum(r["non_converged_registrations"] for r in results)),
        "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    atomic_write_text(output / "manifest.json", json.dumps(manifest, indent=2))
    return StudyOutcome(output, results, computed, skipped, seconds)
