"""The study's result store: resume per (subject, alpha^2), configurations kept apart,
schema checks, safe names, umask, claims, failures and the manifest."""

import dataclasses
import hashlib
import json
import os
import subprocess
import sys
import threading
import time

import pytest

import ladders.study.running.runner as runner_mod
from ladders.study.cohort import Subject, make_synthetic_cohort
from ladders.study.running import SCHEMA_VERSION, StudyConfig, configuration_id, run_study
from ladders.study.running.store import PairStore, atomic_write_text, validate_subject_name

COHORT = make_synthetic_cohort(n_subjects=2, grid=(6, 4), seed=3)
CFG = StudyConfig.build(alpha2=(100.0,), sigma=20.0, max_iter=15, fanning_steps=2)


def _run(config, out, subjects=None, **kw):
    subjects = COHORT.subjects if subjects is None else subjects
    return run_study(config, COHORT.atlas, COHORT.faces, subjects, out, progress=False, **kw)


def _files(out):
    return {p: p.read_bytes() for p in sorted(out.glob("results/*/*/*.json"))}


def _count_registrations(monkeypatch):
    calls = []
    original = runner_mod.compute_pair

    def counting(config, atlas, faces, subject, alpha2, meshes=None):
        out = original(config, atlas, faces, subject, alpha2, meshes)
        calls.append((subject.name, alpha2, out.counts.n_registrations))
        return out

    monkeypatch.setattr(runner_mod, "compute_pair", counting)
    return calls


def test_extending_the_sweep_computes_only_the_new_pairs(tmp_path, monkeypatch):
    calls = _count_registrations(monkeypatch)
    first = _run(CFG, tmp_path)
    assert len(calls) == 2 and all(n > 0 for *_, n in calls)
    before = _files(tmp_path)
    wider = StudyConfig.build(alpha2=(100.0, 1089.0), sigma=20.0, max_iter=15, fanning_steps=2)
    second = _run(wider, tmp_path)
    assert sorted(second.computed) == [(n, 1089.0) for n in COHORT.names]
    assert sorted(second.skipped) == [(n, 100.0) for n in COHORT.names]
    assert [c[:2] for c in calls[2:]] == [(n, 1089.0) for n in COHORT.names]
    assert second.config_id == first.config_id
    after = _files(tmp_path)
    assert all(after[p] == data for p, data in before.items())  # untouched
    assert len(after) == 4
    assert [r.alpha2 for r in second.results] == [(100.0, 1089.0)] * 2


def test_another_configuration_never_touches_earlier_results(tmp_path):
    first = _run(CFG, tmp_path)
    before = _files(tmp_path)
    other = StudyConfig.build(alpha2=(100.0,), sigma=25.0, max_iter=15, fanning_steps=2)
    second = _run(other, tmp_path)
    assert second.config_id != first.config_id and len(second.computed) == 2
    after = _files(tmp_path)
    assert all(after[p] == data for p, data in before.items())
    assert len(after) == 4
    shared = json.loads((tmp_path / "results" / second.config_id / "config.json").read_text())
    assert shared["config"]["registration"]["sigma"] == 25.0
    again = _run(CFG, tmp_path)  # the first configuration is still complete
    assert again.computed == [] and len(again.skipped) == 2


def test_partial_or_corrupt_result_is_recomputed(tmp_path):
    out = _run(CFG, tmp_path)
    store = PairStore(tmp_path, out.config_id)
    a, b = (store.path(n, 100.0) for n in COHORT.names)
    data = json.loads(a.read_text())
    del data["errors"][0]["centrality"]
    a.write_text(json.dumps(data))  # valid JSON, right hash, missing a field
    b.write_text(b.read_text()[:200])  # truncated
    again = _run(CFG, tmp_path)
    assert sorted(again.computed) == [(n, 100.0) for n in COHORT.names]
    assert "centrality" in json.loads(a.read_text())["errors"][0]
    assert again.recomputed == {
        (COHORT.names[0], 100.0): "errors[0]: missing ['centrality']",
        (COHORT.names[1], 100.0): "not valid JSON",
    }


@pytest.mark.parametrize("name", ["", "  ", "..", ".", "../x", "a/b", "a\\b", ".hidden", "a\0b"])
def test_subject_names_cannot_escape_the_output_folder(tmp_path, name):
    s = COHORT.subjects[0]
    with pytest.raises(ValueError, match="subjects: .*name") as info:
        _run(CFG, tmp_path, [Subject(name, s.ed, s.es)])
    assert repr(name) in str(info.value)
    with pytest.raises(ValueError, match="subjects"):
        validate_subject_name(name)
    assert not (tmp_path / "results").exists() or not any(tmp_path.glob("results/*/*/*.json"))


def test_duplicate_names_are_refused(tmp_path):
    s = COHORT.subjects[0]
    with pytest.raises(ValueError, match="repeated: \\['a'\\]"):
        _run(CFG, tmp_path, [Subject("a", s.ed, s.es), Subject("a", s.es, s.ed)])


@pytest.mark.parametrize("mask", [0o022, 0o027, 0o002])
def test_files_follow_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        atomic_write_text(tmp_path / "f.txt", "x")
    finally:
        os.umask(old)
    assert (tmp_path / "f.txt").stat().st_mode & 0o777 == 0o666 & ~mask


def test_a_failing_subject_is_recorded_and_the_others_finish(tmp_path, monkeypatch):
    original = runner_mod.compute_pair
    bad = COHORT.names[0]

    def failing(config, atlas, faces, subject, alpha2, meshes=None):
        if subject.name == bad:
            raise FloatingPointError("norm drift in the fanning scheme")
        return original(config, atlas, faces, subject, alpha2, meshes)

    monkeypatch.setattr(runner_mod, "compute_pair", failing)
    out = _run(CFG, tmp_path)
    assert out.n_failed_subjects == 1
    assert [(f.subject, f.alpha2, f.error) for f in out.failures] == [
        (bad, 100.0, "FloatingPointError: norm drift in the fanning scheme")
    ]
    assert out.results[0].pairs == () and out.results[0].failures
    assert out.results[1].alpha2 == (100.0,)
    stored = json.loads(PairStore(tmp_path, out.config_id).path(bad, 100.0).read_text())
    assert stored["status"] == "failed" and "norm drift" in stored["traceback"]
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["failed_subjects"] == 1
    monkeypatch.setattr(runner_mod, "compute_pair", original)
    retry = _run(CFG, tmp_path)  # failed pairs are retried, finished ones reused
    assert retry.computed == [(bad, 100.0)] and retry.failures == []


def _prepared_result(tmp_path):
    """A finished result of the first subject, computed in another folder."""
    ref = tmp_path / "ref"
    out = _run(CFG, ref, COHORT.subjects[:1])
    return PairStore(ref, out.config_id).path(COHORT.names[0], 100.0).read_bytes()


def test_claims_of_live_runs_prevent_duplicate_work(tmp_path):
    done = _prepared_result(tmp_path)
    out = tmp_path / "out"
    config_id, _ = configuration_id(CFG, COHORT.atlas, COHORT.faces)
    store = PairStore(out, config_id)
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    name = COHORT.names[0]
    try:
        claim = store.path(name, 100.0).with_name("alpha2=100.0.json.claim")
        claim.parent.mkdir(parents=True)
        claim.write_text(json.dumps({"host": os.uname().nodename, "pid": holder.pid}))

        def other_run_finishes():  # the holder stores its result, then releases
            time.sleep(1.0)
            atomic_write_text(store.path(name, 100.0), done.decode())
            claim.unlink()

        t = threading.Thread(target=other_run_finishes)
        t.start()
        res = _run(CFG, out)
        t.join()
    finally:
        holder.kill()
        holder.wait()
    assert res.computed == [(COHORT.names[1], 100.0)]
    assert res.skipped == [(name, 100.0)]
    assert store.path(name, 100.0).read_bytes() == done


def test_stale_claims_of_dead_processes_are_taken_over(tmp_path):
    config_id, _ = configuration_id(CFG, COHORT.atlas, COHORT.faces)
    store = PairStore(tmp_path, config_id)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    claim = store.path(COHORT.names[0], 100.0).with_name("alpha2=100.0.json.claim")
    claim.parent.mkdir(parents=True)
    claim.write_text(json.dumps({"host": os.uname().nodename, "pid": dead.pid}))
    res = _run(CFG, tmp_path)
    assert sorted(res.computed) == [(n, 100.0) for n in COHORT.names]
    assert not claim.exists()


def test_manifest_records_provenance(tmp_path):
    from manifolds.lddmm.kernels import GaussianKernel

    mesh = tmp_path / "atlas.ply"
    mesh.write_bytes(b"ply\nformat ascii 1.0\n")
    out = _run(CFG, tmp_path / "out", data_description={"seed": 7}, input_files=[mesh])
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    versions = manifest["versions"]
    for pkg in ("numpy", "scipy", "autograd", "trimesh", "matplotlib", "joblib", "threadpoolctl"):
        assert versions[pkg], pkg
    assert "numba" in versions and "meshio" in versions
    assert manifest["python"].count(".") == 2
    ran = GaussianKernel(CFG.registration.sigma, backend="auto").backend
    assert manifest["kernel_backend"] == [ran] and ran in ("numpy", "numba")
    assert manifest["kernel_backend_requested"] == "auto"
    assert manifest["command_line"] == sys.argv
    assert manifest["seed"] == 7
    assert manifest["input_files"] == {str(mesh): hashlib.sha256(mesh.read_bytes()).hexdigest()}
    assert manifest["results_folder"] == f"results/{out.config_id}"
    assert manifest["pairs_computed_this_run"] == 2 and manifest["failed_subjects"] == 0
    copy = tmp_path / "out" / "results" / out.config_id / "manifest.json"
    assert json.loads(copy.read_text()) == manifest


def test_a_reused_pid_does_not_hold_a_claim(tmp_path):
    """A live pid whose process started after the claim was written does not hold it."""
    config_id, _ = configuration_id(CFG, COHORT.atlas, COHORT.faces)
    store = PairStore(tmp_path, config_id)
    name = COHORT.names[0]
    claim = store.path(name, 100.0).with_name("alpha2=100.0.json.claim")
    claim.parent.mkdir(parents=True)
    holder = {"host": os.uname().nodename, "pid": os.getpid(), "start": "0"}
    claim.write_text(json.dumps(holder))
    if not os.path.exists(f"/proc/{os.getpid()}/stat"):
        pytest.skip("process start times need /proc")
    assert store.claim_is_stale(name, 100.0)
    claim.unlink()
    assert store.claim(name, 100.0)  # our own live claim holds
    assert not store.claim_is_stale(name, 100.0) and not store.claim(name, 100.0)
    store.release(name, 100.0)
    assert not claim.exists()


def test_a_non_finite_result_is_recorded_as_failed(tmp_path, monkeypatch):
    original = runner_mod.compute_pair

    def nan_centrality(config, atlas, faces, subject, alpha2, meshes=None):
        out = original(config, atlas, faces, subject, alpha2, meshes)
        if subject.name == COHORT.names[1]:
            errors = (dataclasses.replace(out.errors[0], centrality=float("nan")), out.errors[1])
            out = dataclasses.replace(out, errors=errors)
        return out

    monkeypatch.setattr(runner_mod, "compute_pair", nan_centrality)
    out = _run(CFG, tmp_path)
    assert [f.subject for f in out.failures] == [COHORT.names[1]]
    assert out.failures[0].error.endswith("non-finite: residual.centrality")


def test_a_result_of_an_older_schema_is_recomputed_with_a_message(tmp_path, capsys):
    """A file written before the typed results (no schema_version) is never read half-way."""
    from ladders.study.cli import main

    first = _run(CFG, tmp_path, COHORT.subjects[:1])
    path = PairStore(tmp_path, first.config_id).path(COHORT.names[0], 100.0)
    data = json.loads(path.read_text())
    old = {k: v for k, v in data.items() if k not in ("schema_version", "errors")}
    old["residual"] = {"centrality": 1.0}  # the layout of schema 1
    path.write_text(json.dumps(old))
    again = _run(CFG, tmp_path, COHORT.subjects[:1])
    assert again.computed == [(COHORT.names[0], 100.0)]
    reason = again.recomputed[(COHORT.names[0], 100.0)]
    assert reason == f"written with result schema 1, this version reads schema {SCHEMA_VERSION}"
    assert json.loads(path.read_text())["schema_version"] == SCHEMA_VERSION
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["pairs_recomputed"] == [
        {"subject": COHORT.names[0], "alpha2": 100.0, "reason": reason}
    ]
    # The command line says so on standard error.
    path.write_text(json.dumps(old))
    args = ["study", "--subjects", "1", "--vertices", "25", "-o", str(tmp_path / "cli")]
    args += ["--alpha2", "100", "--max-iter", "15", "--fanning-steps", "2", "--jobs", "1"]
    assert main([*args, "--no-progress", "--no-meshes"]) == 0
    (stored,) = (tmp_path / "cli" / "results").glob("*/*/alpha2=100.0.json")
    stored.write_text(json.dumps({**json.loads(stored.read_text()), "schema_version": 1}))
    capsys.readouterr()
    assert main([*args, "--no-progress", "--no-meshes"]) == 0
    err = capsys.readouterr().err
    assert (
        "note: 1 stored (subject, alpha^2) result(s) were computed again: written with "
        f"result schema 1, this version reads schema {SCHEMA_VERSION}"
    ) in err
