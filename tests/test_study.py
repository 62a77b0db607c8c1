"""The paper's Section 3 study on a small cohort: outputs, qualitative findings, resume, CLI."""

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ladders.study.cli import main
from ladders.study.cohort import make_synthetic_cohort, write_cohort
from ladders.study.reporting import summarize, write_report
from ladders.study.running import ERROR_NAMES, VARIANTS, StudyConfig, run_study

ALPHA2 = (0.01, 1.0, 100.0)
CONFIG = StudyConfig.build(alpha2=ALPHA2, sigma=20.0, max_iter=60, fanning_steps=5)
COHORT = make_synthetic_cohort(n_subjects=3, grid=(8, 5), seed=0)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("study")
    outcome = run_study(CONFIG, COHORT.atlas, COHORT.faces, COHORT.subjects, out, progress=False)
    shapes = {s.name: s.ed for s in COHORT.subjects}
    paths = write_report(outcome.results, out, COHORT.atlas, COHORT.faces, shapes)
    return outcome, paths


def _means(results, variant, name):
    return {a: np.mean([r.at(a).measure(variant, name) for r in results]) for a in ALPHA2}


def test_outputs_are_written_and_readable(study):
    outcome, paths = study
    for key in ("summary_csv", "summary_md", "errors_png", "ase_png", "maps_png"):
        assert paths[key].stat().st_size > 0
    for key in ("errors_png", "ase_png", "maps_png"):
        assert paths[key].read_bytes()[:4] == b"\x89PNG"
    manifest = json.loads((outcome.output / "manifest.json").read_text())
    assert manifest["n_subjects"] == 3 and manifest["config"]["alpha2"] == list(ALPHA2)
    folder = outcome.output / "results" / outcome.config_id
    assert sorted(p.name for p in folder.iterdir() if p.is_dir()) == COHORT.names
    for name in COHORT.names:
        files = sorted(p.name for p in (folder / name).glob("*.json"))
        assert files == sorted(f"alpha2={a!r}.json" for a in ALPHA2)
    table = paths["summary_md"].read_text()
    assert "Centrality" in table and "Transvectivity" in table and "Inverse cons." in table
    rows = paths["summary_csv"].read_text().splitlines()
    assert rows[0] == "alpha2,measure,variant,mean,std,n"
    assert len(rows) - 1 == len(summarize(outcome.results))
    tidy = paths["results_csv"].read_text().splitlines()
    assert tidy[0] == "subject,alpha2,variant,measure,value,unit"
    assert len(tidy) - 1 == len(COHORT) * len(ALPHA2) * (2 * 9 + 1)
    assert "Wilcoxon p" in table and "Residual lower" in table
    paired = paths["paired_csv"].read_text().splitlines()
    assert len(paired) - 1 == len(ALPHA2) * 5


def test_fig5b_shows_the_median_subject_without_white_margins(study):
    from matplotlib.image import imread

    outcome, paths = study
    ase = {r.subject: r.at(1.0).measure("residual", "ase") for r in outcome.results}
    ranked = sorted(ase, key=ase.get)
    assert paths["maps_subject"] == ranked[len(ranked) // 2]  # 3 subjects: the middle one
    image = imread(paths["maps_png"])[..., :3]
    ink = np.argwhere((image < 0.97).any(axis=2))  # pixels that are not white
    (top, left), (bottom, right) = ink.min(axis=0), ink.max(axis=0)
    height, width = image.shape[:2]
    assert top <= 0.04 * height and bottom >= 0.96 * height  # margins under 4 %
    assert left <= 0.04 * width and right >= 0.96 * width


def test_cli_exit_status_counts_failed_subjects(tmp_path, monkeypatch, capsys):
    import ladders.study.running.runner as runner_mod

    original = runner_mod.compute_pair

    def failing(config, atlas, faces, subject, alpha2, meshes=None):
        if subject.name == COHORT.names[1]:
            raise RuntimeError("the norm drift guard tripped")
        return original(config, atlas, faces, subject, alpha2, meshes)

    monkeypatch.setattr(runner_mod, "compute_pair", failing)
    meshes = write_cohort(COHORT, tmp_path / "meshes", ext="ply")
    args = [
        "study", "--meshes", str(meshes), "--output", str(tmp_path / "o"), "--alpha2", "100",
        "--max-iter", "15", "--fanning-steps", "2", "--jobs", "1", "--no-progress",
    ]  # fmt: skip
    assert main(args) == 1
    assert "1 subject(s) failed" in capsys.readouterr().err
    summary = (tmp_path / "o" / "summary.md").read_text()
    assert f"{COHORT.names[1]}, α² = 100: RuntimeError: the norm drift guard tripped" in summary
    manifest = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert len(manifest["input_files"]) == 1 + 2 * len(COHORT)


def test_residuals_improve_midpoint_centrality_involutivity(study):
    outcome, _ = study
    for name in ("midpoint_distance", "centrality", "involutivity"):
        with_res = _means(outcome.results, "residual", name)
        without = _means(outcome.results, "no_residual", name)
        for a in ALPHA2:
            if a >= 1:
                assert with_res[a] < without[a], (name, a, with_res[a], without[a])


def test_registration_error_grows_and_norm_shrinks_with_alpha(study):
    outcome, _ = study
    for r in outcome.results:
        errs = [r.at(a).registration.error for a in ALPHA2]
        norms = [r.at(a).registration.rkhs_norm for a in ALPHA2]
        assert np.all(np.diff(errs) > 0), errs
        assert np.all(np.diff(norms) < 0), norms


def test_each_result_is_complete_and_finite(study):
    outcome, _ = study
    k = COHORT.n_vertices
    for r in outcome.results:
        for a in ALPHA2:
            node = r.at(a)
            assert node.non_finite_fields() == []
            for variant in VARIANTS:
                for name in (*ERROR_NAMES, "ase"):
                    assert np.isfinite(node.measure(variant, name))
                    assert node.measure(variant, name) >= 0
            assert [t.method for t in node.transports] == [
                "pole_ladder_residual", "pole_ladder_no_residual", "fanning"
            ]  # fmt: skip
            assert np.isfinite(node.transport("fanning").ase)
            assert len(node.las_subject) == k and all(len(t.las) == k for t in node.transports)
            assert node.counts.n_registrations <= 13  # shared registrations are not repeated
            assert node.counts.n_flow_evaluations >= node.counts.n_iterations > 0


def test_resume_after_partial_run_gives_identical_results(study, tmp_path):
    outcome, _ = study
    run_study(CONFIG, COHORT.atlas, COHORT.faces, COHORT.subjects[:1], tmp_path, progress=False)
    resumed = run_study(
        CONFIG, COHORT.atlas, COHORT.faces, COHORT.subjects, tmp_path, progress=False
    )
    assert resumed.skipped == [(COHORT.names[0], a) for a in ALPHA2]
    assert sorted(resumed.computed) == [(n, a) for n in COHORT.names[1:] for a in ALPHA2]
    for got, ref in zip(resumed.results, outcome.results, strict=True):
        for a in ALPHA2:
            strip = dataclasses.replace(got.at(a), seconds=0.0)
            assert strip == dataclasses.replace(ref.at(a), seconds=0.0)
    assert summarize(resumed.results) == summarize(outcome.results)


def test_changed_parameters_are_recomputed(tmp_path):
    cohort = COHORT.head(1)
    cfg = StudyConfig.build(alpha2=(100.0,), sigma=20.0, max_iter=20, fanning_steps=3)
    run_study(cfg, cohort.atlas, cohort.faces, cohort.subjects, tmp_path, progress=False)
    again = run_study(cfg, cohort.atlas, cohort.faces, cohort.subjects, tmp_path, progress=False)
    assert again.computed == [] and again.skipped == [(cohort.names[0], 100.0)]
    other = StudyConfig.build(alpha2=(100.0,), sigma=25.0, max_iter=20, fanning_steps=3)
    third = run_study(other, cohort.atlas, cohort.faces, cohort.subjects, tmp_path, progress=False)
    assert third.computed == [(cohort.names[0], 100.0)]


def test_cli_on_a_mesh_folder_and_kill_then_resume(tmp_path):
    meshes = write_cohort(COHORT, tmp_path / "meshes", ext="vtk")
    out = tmp_path / "out"
    args = [
        "study", "--meshes", str(meshes), "--output", str(out), "--alpha2", "1,100",
        "--max-iter", "30", "--fanning-steps", "3", "--jobs", "1", "--no-progress",
    ]  # fmt: skip
    # Kill the run as soon as the first subject is stored, then resume.
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from ladders.study.cli import main; sys.exit(main())",
            *args,
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        cwd=Path(__file__).resolve().parents[1],
    )
    deadline = time.time() + 120
    while time.time() < deadline and not list(out.glob("results/*/*/*.json")):
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = list(out.glob("results/*/*/*.json"))
    assert finished, "no subject finished before the kill"
    for f in finished:
        json.loads(f.read_text())  # complete files only
    assert main(args) == 0
    assert len(list(out.glob("results/*/*/*.json"))) == 2 * len(COHORT)
    assert (out / "summary.md").exists() and (out / "fig4_symmetry_errors.png").exists()


def test_cli_rejects_mismatched_meshes(tmp_path, capsys):
    from ladders.study.meshes import write_mesh

    meshes = write_cohort(COHORT.head(1), tmp_path / "meshes", ext="ply")
    other = make_synthetic_cohort(1, grid=(6, 4), seed=1)
    write_mesh(meshes / f"{COHORT.names[0]}_es.ply", other.subjects[0].es, other.faces)
    args = ["study", "--meshes", str(meshes), "--output", str(tmp_path / "o"), "--no-progress"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "vertices" in err and f"{COHORT.names[0]}_es.ply" in err
    assert main([*args[:2], str(tmp_path / "missing"), *args[3:]]) == 2
    assert "missing" in capsys.readouterr().err


def test_dask_backend_gives_the_same_results(study, tmp_path):
    distributed = pytest.importorskip("distributed")
    from joblib import parallel_config

    outcome, _ = study
    cohort = COHORT.head(2)
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=2) as client:
        assert client.status == "running"
        with parallel_config(backend="dask"):
            res = run_study(
                CONFIG, cohort.atlas, cohort.faces, cohort.subjects, tmp_path, progress=False
            )
    assert sorted({name for name, _ in res.computed}) == cohort.names
    # Other threads, other BLAS summation orders: equal up to round-off, not bitwise.
    for got, ref in zip(res.results, outcome.results[:2], strict=True):
        np.testing.assert_allclose(_leaves(got.pairs), _leaves(ref.pairs), rtol=1e-6)


def _leaves(node):
    # Numbers only, without the timings. The count of non-converged registrations is
    # kept: each space counts its own, so concurrent threads cannot mix them up.
    if dataclasses.is_dataclass(node):
        node = dataclasses.asdict(node)
    if isinstance(node, dict):
        keep = [k for k in sorted(node) if k != "seconds" and not isinstance(node[k], str)]
        return np.concatenate([_leaves(node[k]) for k in keep])
    if isinstance(node, (list, tuple)) and node and not isinstance(node[0], (int, float)):
        return np.concatenate([_leaves(v) for v in node])
    return np.atleast_1d(np.asarray(node, dtype=float)).ravel()


@pytest.mark.parametrize(
    ("grid", "settings"),
    [
        ((12, 8), {}),  # the study's default: sigma = 10 mm, a 0.7 sigma sample of the vertices
        ((10, 6), dict(sigma=20.0, control_points="dense", max_iter=3000)),
    ],
    ids=["default-vertices", "dense"],
)
def test_claim_a_holds_at_every_alpha_with_control_points_at_the_vertices(tmp_path, grid, settings):
    """With control points on the shape (the study's default sample of the vertices, or
    every vertex) the registration is well posed, and residuals lower the midpoint
    distance, centrality and involutivity at every alpha^2 of the paper's sweep, for
    the mean over the subjects and for most subjects (the paper's claim (a);
    docs/evidence/study_results.md)."""
    from ladders.study.cli.study_arguments import FULL_ALPHA2

    cohort = make_synthetic_cohort(n_subjects=3, grid=grid, seed=0)
    config = StudyConfig.build(alpha2=FULL_ALPHA2, fanning_steps=3, **settings)
    out = run_study(
        config, cohort.atlas, cohort.faces, cohort.subjects, tmp_path, progress=False, meshes=False
    )
    assert all(r.non_converged_registrations == 0 for r in out.results)
    for a in FULL_ALPHA2:
        for name in ("midpoint_distance", "centrality", "involutivity"):
            with_res = np.array([r.at(a).measure("residual", name) for r in out.results])
            without = np.array([r.at(a).measure("no_residual", name) for r in out.results])
            assert with_res.mean() < without.mean(), (a, name, with_res, without)
            assert np.sum(with_res < without) >= 2, (a, name, with_res, without)


def test_one_job_with_parallel_kernel_sums_gives_the_results_of_two_workers(tmp_path):
    """A lone run lets the kernel sums use every core (1,009 vertices x 143 control points
    is above the parallel threshold); two workers keep one thread each. Same numbers."""
    from ladders.study.running.result_codec import encode

    cohort = make_synthetic_cohort(2, seed=3)
    config = StudyConfig.build(alpha2=(1.0,))
    runs = {
        jobs: run_study(
            config,
            cohort.atlas,
            cohort.faces,
            cohort.subjects,
            tmp_path / str(jobs),
            jobs=jobs,
            progress=False,
            meshes=False,
        )  # fmt: skip
        for jobs in (1, 2)
    }

    def numbers(outcome):
        out = []
        for r in outcome.results:
            d = encode(r.at(1.0))
            d.pop("seconds", None)
            out.append(json.dumps(d, sort_keys=True))
        return out

    assert numbers(runs[1]) == numbers(runs[2])
