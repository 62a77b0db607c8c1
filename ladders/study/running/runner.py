"""Running the study over a cohort: parallel subjects, resumable per (subject, alpha^2)."""

from __future__ import annotations

import json
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..batch import run_batch
from ..cohort import Subject
from ..errors import CohortError
from ..files import array_digest, atomic_write_text, config_hash
from ..meshes.mesh_io import write_mesh
from .pipeline import StudyConfig, compute_pair
from .provenance import write_manifest
from .results import FailedPair, PairResult, SubjectResults
from .store import PairStore, validate_subject_name

__all__ = ["StudyOutcome", "run_study", "configuration_id", "ATLAS_FILE"]

_CLAIM_POLL_S = 0.5  # how often a run checks pairs claimed by another run
#: The atlas and faces of a configuration's results, next to its ``config.json``.
ATLAS_FILE = "atlas.vtu"


@dataclass
class StudyOutcome:
    """What :func:`run_study` returns.

    Attributes
    ----------
    output : Path
        The results folder.
    results : list of SubjectResults
        Per subject, in the cohort's order: its successful pairs and its failures.
    computed, skipped : list of (str, float)
        Pairs computed by this run / reused from earlier (or concurrent) runs.
    seconds : float
        Wall time of this run.
    failures : list of FailedPair
        Every pair that raised.
    config_id : str
        Folder of this configuration under ``output/results/``.
    recomputed : dict
        ``(subject, alpha2) -> reason`` for the stored files that could not be
        used (another result schema, a missing field, ...) and were computed again.
    """

    output: Path
    results: list[SubjectResults]
    computed: list
    skipped: list
    seconds: float
    failures: list[FailedPair] = field(default_factory=list)
    config_id: str = ""
    recomputed: dict = field(default_factory=dict)

    @property
    def n_failed_subjects(self) -> int:
        """Number of subjects with at least one failed pair."""
        return len({f.subject for f in self.failures})


def configuration_id(config: StudyConfig, atlas, faces) -> tuple[str, dict]:
    """Hash (and content) of what the results depend on besides alpha^2 and the subject.

    The registration settings enter through their key, which includes the kernel
    backend that runs (the compiled kernels' results differ from numpy's in the
    last bits).
    """
    cfg = config.as_dict()
    cfg.pop("alpha2")
    shared = {"config": cfg, "atlas": array_digest(atlas), "faces": array_digest(faces)}
    return config_hash(shared), shared


def _pair_hash(config_id: str, subject: Subject, alpha2: float) -> str:
    ed, es = array_digest(subject.ed), array_digest(subject.es)
    return config_hash({"config": config_id, "alpha2": float(alpha2), "ed": ed, "es": es})


def _attempt(config, atlas, faces, subject, alpha2, meshes=None) -> PairResult | FailedPair:
    """:func:`compute_pair`, with any exception (or non-finite number) recorded as a failure."""
    start = time.perf_counter()
    try:
        out = compute_pair(config, atlas, faces, subject, alpha2, meshes)
    except Exception as exc:  # a failing subject must not stop the others
        error, trace = f"{type(exc).__name__}: {exc}", traceback.format_exc()
    else:
        bad = out.non_finite_fields()
        if not bad:
            return out
        error, trace = f"incomplete result, missing or non-finite: {', '.join(bad)}", ""
    return FailedPair(subject.name, alpha2, error, trace, time.perf_counter() - start)


def _subject_task(config, atlas, faces, subject, alphas, store, config_id, meshes=None) -> dict:
    """Worker: compute the subject's pairs it can claim; each is stored as it finishes."""
    report = {"subject": subject.name, "computed": [], "busy": []}
    for a2 in alphas:
        if not store.claim(subject.name, a2):
            report["busy"].append(a2)  # another run is computing it
            continue
        finished = store.load(subject.name, a2, _pair_hash(config_id, subject, a2))
        if isinstance(finished, PairResult):
            store.release(subject.name, a2)  # another run finished it meanwhile
            continue
        try:
            result = _attempt(config, atlas, faces, subject, a2, meshes)
            store.save(result, _pair_hash(config_id, subject, a2))
        finally:
            store.release(subject.name, a2)
        report["computed"].append(a2)
    return report


def _stored_subject(config, atlas, faces, subject, alphas, store, config_id, meshes=None):
    """The report of a subject whose pairs are all stored with a result (None: it runs)."""
    # Every pair is read, so that the store notes each unusable one (``store.unusable``).
    stored = [store.load(subject.name, a2, _pair_hash(config_id, subject, a2)) for a2 in alphas]
    if not all(isinstance(r, PairResult) for r in stored):
        return None
    return {"subject": subject.name, "computed": [], "busy": []}


def _run_parallel(tasks, jobs: int, progress: bool) -> list[dict]:
    return list(run_batch(_subject_task, tasks, jobs=jobs, progress=progress, desc="subjects",
                          unit="subject", ordered=False, reuse=_stored_subject))  # fmt: skip


def _wait_for_other_runs(busy, by_name, store, config, atlas, faces, config_id, meshes) -> list:
    """Wait for pairs claimed by other runs; take over those whose holder died."""
    busy, taken_over = list(busy), []
    if busy:
        print(
            f"waiting for {len(busy)} (subject, alpha^2) pair(s) claimed by another run",
            file=sys.stderr,
        )
    while busy:
        left = []
        for name, a2 in busy:
            subject = by_name[name]
            if store.load(name, a2, _pair_hash(config_id, subject, a2)) is not None:
                continue
            if store.claim_is_stale(name, a2):
                task = (config, atlas, faces, subject, [a2], store, config_id, meshes)
                rep = list(run_batch(_subject_task, [task]))[0]
                taken_over += [(name, a) for a in rep["computed"]]
                left += [(name, a) for a in rep["busy"]]
            else:
                left.append((name, a2))
        busy = left
        if busy:
            time.sleep(_CLAIM_POLL_S)
    return taken_over


def _collect(subjects, alphas, store, config_id) -> list[SubjectResults]:
    """Per subject, the stored results of the pairs in the sweep."""
    results = []
    for s in subjects:
        stored = [store.load(s.name, a2, _pair_hash(config_id, s, a2)) for a2 in alphas]
        if any(r is None for r in stored):
            a2 = alphas[stored.index(None)]
            raise RuntimeError(f"result of subject {s.name!r} at alpha2={a2:g} missing")
        pairs = tuple(r for r in stored if isinstance(r, PairResult))
        failures = tuple(r for r in stored if isinstance(r, FailedPair))
        results.append(SubjectResults(s.name, pairs, failures))
    return results


def _check_subjects(subjects) -> None:
    names = [validate_subject_name(s.name) for s in subjects]
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise CohortError(f"subjects: subject names must be unique, repeated: {dup}")


def run_study(
    config: StudyConfig,
    atlas: np.ndarray,
    faces: np.ndarray,
    subjects: list[Subject],
    output: str | Path,
    jobs: int = 1,
    progress: bool = True,
    data_description: dict | None = None,
    input_files: list | None = None,
    meshes: bool = True,
) -> StudyOutcome:
    """Run (or resume) the study; write per-(subject, alpha^2) results and a manifest.

    Parameters
    ----------
    config : StudyConfig
    atlas : array, shape (k, 3)
        The template ``T``.
    faces : int array, shape (f, 3)
        Triangles shared by all meshes (vertex correspondence).
    subjects : list of Subject
        Names must be plain file names (no path separator, not ``..``).
    output : path
        Results folder; each pair is stored as soon as it finishes (layout:
        :mod:`ladders.study.running.store`). Rerunning resumes; extending the alpha^2 sweep
        computes only the new pairs; other settings go to another folder. A
        pair that raised is stored with its error and retried on the next run.
    jobs : int
        Parallel workers (joblib); ``-1`` uses all cores. With one job the kernel sums
        use every core; with several, each worker's share of them
        (:func:`~manifolds.kernels.threads_per_worker`: no oversubscription). Inside a
        ``joblib.parallel_config(backend="dask")`` block the subjects run on
        a Dask cluster instead.
    progress : bool
        Show a progress bar (tqdm).
    data_description : dict, optional
        Recorded in the manifest (e.g. the cohort generator's parameters, ``seed``).
    input_files : list of path, optional
        Mesh files the cohort was read from; their SHA-256 go into the manifest.
    meshes : bool, default True
        Write each computed pair's shapes and strain maps as ``.vtu`` files under
        ``output/meshes/<config>`` (:mod:`ladders.study.meshes.mesh_outputs`).

    Returns
    -------
    StudyOutcome
    """
    start = time.perf_counter()
    _check_subjects(subjects)
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    config_id, shared = configuration_id(config, atlas, faces)
    store = PairStore(output, config_id)
    atomic_write_text(store.root / "config.json", json.dumps(shared, indent=2))
    write_mesh(store.root / ATLAS_FILE, atlas, faces, atomic=True)
    alphas = [float(a) for a in config.alpha2]
    by_name = {s.name: s for s in subjects}
    mesh_folder = output / "meshes" / config_id if meshes else None
    # Every subject with the whole sweep: the runner reuses those stored in full
    # (_stored_subject), and a worker skips the pairs already stored with a result.
    tasks = [(config, atlas, faces, s, alphas, store, config_id, mesh_folder) for s in subjects]
    reports = _run_parallel(tasks, jobs, progress)
    recomputed = dict(store.unusable)  # noted by the reuse check before anything ran
    computed = [(r["subject"], a) for r in reports for a in r["computed"]]
    busy = [(r["subject"], a) for r in reports for a in r["busy"]]
    computed += _wait_for_other_runs(
        busy, by_name, store, config, atlas, faces, config_id, mesh_folder
    )
    results = _collect(subjects, alphas, store, config_id)
    failures = [f for r in results for f in r.failures]
    done_now = set(computed)
    skipped = [(s.name, a) for s in subjects for a in alphas if (s.name, a) not in done_now]
    outcome = StudyOutcome(
        output, results, computed, skipped, time.perf_counter() - start, failures, config_id,
        recomputed,
    )  # fmt: skip
    write_manifest(outcome, config, atlas, faces, jobs, data_description or {}, input_files or [])
    return outcome
