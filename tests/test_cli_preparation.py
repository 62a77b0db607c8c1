"""``symladders correspond`` and ``symladders atlas``: outputs, exit statuses, resume, interruption."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import ladders.study.preparation as preparation
import ladders.study.preparation.atlas_run as atlas_run
from ladders.study import read_mesh, write_mesh
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.preparation import remesh, simulate_segmentations

from .cli_runner import run_cli


@pytest.fixture(scope="module")
def corresponded(tmp_path_factory):
    """Two remeshed, moved subjects and an unreadable one, corresponded twice (a rerun)."""
    root = tmp_path_factory.mktemp("correspond")
    cohort = make_synthetic_cohort(2, n_vertices=150, seed=1)
    simulate_segmentations(cohort, root / "seg", np.random.default_rng(1), ext=".obj")
    for phase in ("ed", "es"):
        (root / "seg" / f"broken_{phase}.obj").write_text("not a mesh")
    argv = ["correspond", "--atlas", root / "seg" / "atlas.vtk", "--meshes", root / "seg",
            "-o", root / "out", "-j", "1", "--ext", "ply"]  # fmt: skip
    return root, cohort, run_cli(*argv), run_cli(*argv, "--no-progress")


def test_a_failing_subject_exits_1_and_the_others_finish(corresponded):
    root, cohort, (status, out, err), _ = corresponded
    assert status == 1
    assert err.splitlines() == [
        f"symladders correspond: 1 subject(s) failed (broken); reasons in {root / 'out/quality.md'}"
    ]
    lines = out.splitlines()
    assert lines[0].startswith("symladders correspond: 3 subject(s) from")
    assert [ln.split(":")[0] for ln in lines[1:4]] == [
        "[1/3] broken", "[2/3] synthetic_000", "[3/3] synthetic_001"
    ]  # fmt: skip
    assert "failed (MeshFolderError" in lines[1] and "mean surface distance ED" in lines[2]
    assert lines[-1] == (
        "symladders correspond: 3 subject(s): 2 corresponded, 0 reused, 1 failed; 2 mesh(es) "
        f"flagged for inspection: broken ed, broken es; quality table: {root / 'out/quality.md'}"
    )
    names = sorted(p.name for p in (root / "out").glob("*.ply"))
    assert names == [
        "atlas.ply",
        *(f"{s.name}_{p}.ply" for s in cohort.subjects for p in ("ed", "es")),
    ]


def test_a_rerun_skips_the_subjects_done_and_retries_the_failed(corresponded):
    _, _, _, (status, out, _) = corresponded
    assert status == 1 and len(out.splitlines()) == 2  # the first line and the summary
    assert "0 corresponded, 2 reused, 1 failed" in out.splitlines()[-1]


def test_the_study_reads_the_output_folder(corresponded, tmp_path):
    root, cohort, _, _ = corresponded
    status, out, err = run_cli("study", "--meshes", root / "out", "-o", tmp_path, "--alpha2",
                               "1089", "--sigma", "20", "--max-iter", "100", "--no-progress",
                               "--no-meshes", "-j", "1")  # fmt: skip
    assert status == 0, err
    assert "synthetic_000" in (tmp_path / "results.csv").read_text()
    assert "Lengths in mm" in (tmp_path / "summary.md").read_text()


def test_the_flags_reach_the_library(tmp_path, monkeypatch):
    seen = {}

    def fake(atlas, meshes, output, settings, **kwargs):
        seen.update(kwargs, settings=settings, meshes=meshes)
        return preparation.CohortCorrespondence(Path(output))

    monkeypatch.setattr(preparation, "correspond_cohort", fake)
    cohort = make_synthetic_cohort(1, n_vertices=150, seed=0)
    simulate_segmentations(cohort, tmp_path / "seg", np.random.default_rng(0))
    status, out, _ = run_cli(
        "correspond", "--atlas", tmp_path / "seg" / "atlas.vtk", "--meshes", tmp_path / "seg",
        "-o", tmp_path / "out", "--units", "m", "--allow-scale", "--allow-pose", "--alignment",
        "none", "--sigma-w", "7", "--weight", "0.5", "--no-resume", "-j", "2", "--no-progress",
        "--landmark-anchor", "points",
    )  # fmt: skip
    assert status == 0 and "0 corresponded, 0 reused, 0 failed" in out
    assert list(seen["meshes"]) == ["synthetic_000"]
    s = seen.pop("settings")
    assert (s.sigma_w, s.weight, s.alignment, s.anchor) == (7.0, 0.5, "none", "points")
    assert seen["units"] == "m" and seen["allow_scale"] and seen["allow_pose"] is True
    assert seen["resume"] is False and seen["jobs"] == 2 and seen["progress"] is None
    status, _, _ = run_cli("correspond", "--atlas", tmp_path / "seg" / "atlas.vtk", "--meshes",
                           tmp_path / "seg", "-o", tmp_path / "out")  # fmt: skip
    assert seen["allow_pose"] is None and seen["resume"] is True and seen["units"] is None
    assert seen["settings"] == preparation.CorrespondenceSettings()  # the library's defaults
    run_cli("correspond", "--atlas", tmp_path / "seg" / "atlas.vtk", "--meshes", tmp_path / "seg",
            "-o", tmp_path / "out", "--landmark-anchor", "none")  # fmt: skip
    assert seen["settings"].anchor_weight == 0.0
    run_cli("correspond", "--atlas", tmp_path / "seg" / "atlas.vtk", "--meshes", tmp_path / "seg",
            "-o", tmp_path / "out", "--flag-hausdorff", "8", "--flag-mean-distance", "0.7")  # fmt: skip
    flags = seen["settings"]
    assert (flags.flag_hausdorff, flags.flag_mean_distance) == (8.0, 0.7)
    # thresholds that only read the quality do not make the results new
    assert flags.key() == preparation.CorrespondenceSettings().key()
    assert flags.replace(alpha=1.0).key() != flags.key()
    status, _, err = run_cli("correspond", "--atlas", tmp_path / "seg" / "atlas.vtk", "--meshes",
                             tmp_path / "seg", "-o", tmp_path / "out", "--flag-hausdorff", "-1")  # fmt: skip
    assert status == 2 and "--flag-hausdorff" in err


# ------------------------------------------------------------------ atlas
@pytest.fixture
def atlas_folder(corresponded, tmp_path):
    """The corresponded meshes (one vertex count and triangulation), without the atlas."""
    folder = tmp_path / "meshes"
    shutil.copytree(corresponded[0] / "out", folder, ignore=shutil.ignore_patterns("atlas.*"))
    return folder


def test_atlas_of_corresponding_meshes(corresponded, atlas_folder, tmp_path):
    status, out, err = run_cli("atlas", "--meshes", atlas_folder, "-o", tmp_path / "a" / "T.obj",
                               "--start", "mean", "--tol", "0.05")  # fmt: skip
    assert status == 0, err
    record = json.loads((tmp_path / "a" / "T.json").read_text())
    assert record["term"] == "landmarks" and record["start"] == "mean"
    assert len(record["objectives"]) == record["n_iter"] + 1
    lines = out.splitlines()
    assert lines[1].startswith("start: objective ") and len(lines) == record["n_iter"] + 3
    state = "converged" if record["converged"] else "not converged"
    assert lines[-1].startswith(f"symladders atlas: {state} after {record['n_iter']} iteration(s)")
    _, faces = read_mesh(tmp_path / "a" / "T.obj")  # the corresponded meshes' triangulation
    np.testing.assert_array_equal(faces, read_mesh(corresponded[0] / "out" / "atlas.ply")[1])


def test_build_atlas_is_what_the_command_runs(atlas_folder, tmp_path):
    """The Python path of ``symladders atlas``: the same record, errors naming the argument."""
    seen = []
    run = atlas_run.build_atlas(atlas_folder, tmp_path / "A.vtk", term="varifold", max_iter=1,
                                progress=lambda it, f, n: seen.append(f))  # fmt: skip
    record = json.loads(run.record_path.read_text())
    assert record == json.loads(json.dumps(run.record, default=str))
    assert record["term"] == "varifold" and record["settings"]["data_term"] == "varifold"
    assert record["objectives"] == seen and record["n_iter"] == 1
    assert read_mesh(tmp_path / "A.vtk")[0].shape == run.result.vertices.shape
    with pytest.raises(ValueError, match="^start 'nobody'"):
        atlas_run.build_atlas(atlas_folder, tmp_path / "B.vtk", start="nobody")
    with pytest.raises(ValueError, match="^term: expected one of"):
        atlas_run.build_atlas(atlas_folder, tmp_path / "B.vtk", term="landmark")
    assert not (tmp_path / "B.vtk").exists()


def test_an_interrupted_atlas_keeps_its_last_iterate(atlas_folder, tmp_path, monkeypatch):
    def interrupted(meshes, settings, **kwargs):
        kwargs["checkpoint"](0, meshes[0][0])
        kwargs["checkpoint"](1, meshes[0][0] + 1.0)
        raise KeyboardInterrupt

    monkeypatch.setattr(atlas_run, "estimate_atlas", interrupted)
    output = tmp_path / "T.vtk"
    status, _, err = run_cli("atlas", "--meshes", atlas_folder, "-o", output)
    assert status == 130
    assert err.strip() == (
        f"symladders atlas: interrupted; the iterate of iteration 1 was written to {output}; "
        f"continue with --start {output}"
    )
    record = json.loads(output.with_suffix(".json").read_text())
    assert record["interrupted"] and not record["converged"] and record["n_iter"] == 1
    monkeypatch.undo()
    status, out, err = run_cli("atlas", "--meshes", atlas_folder, "-o", tmp_path / "T2.vtk",
                               "--start", output, "--max-iter", "1")  # fmt: skip
    assert status == 0, err
    assert json.loads((tmp_path / "T2.json").read_text())["start"] == str(output.resolve())


def test_atlas_start_errors(atlas_folder, tmp_path):
    def error(*flags) -> str:
        status, _, err = run_cli("atlas", "--meshes", atlas_folder, "-o", tmp_path / "T.vtk",
                                 *flags)  # fmt: skip
        assert status == 2 and len(err.splitlines()) == 1, err
        return err

    assert "--start 'synthetc_000': no subject of that name and no mesh file; did you mean " \
        "'synthetic_000'?" in error("--start", "synthetc_000")  # fmt: skip
    v, f = read_mesh(atlas_folder / "synthetic_000_ed.ply")
    start = write_mesh(tmp_path / "start.vtk", *remesh(v, f, 200))  # another triangulation
    assert "--term landmarks: the meshes (and the start) do not share" in error(
        "--start", start, "--term", "landmarks"
    )


def test_an_unreadable_ed_mesh_is_left_out_with_status_1(atlas_folder, tmp_path):
    (atlas_folder / "broken_ed.ply").write_text("not a mesh")
    status, _, err = run_cli("atlas", "--meshes", atlas_folder, "-o", tmp_path / "T.vtk",
                             "--max-iter", "1", "--no-progress")  # fmt: skip
    assert status == 1
    assert err.startswith("symladders atlas: warning: broken left out: MeshFolderError")
    record = json.loads((tmp_path / "T.json").read_text())
    assert list(record["skipped"]) == ["broken"] and "broken" not in record["subjects"]


def test_atlas_of_a_subset_and_a_rerun_that_reuses_it(atlas_folder, tmp_path):
    argv = ["atlas", "--meshes", atlas_folder, "-o", tmp_path / "T.vtk", "--subset", "1",
            "--subset-rule", "random", "--subset-seed", "3", "--max-iter", "1", "-j", "1"]  # fmt: skip
    status, out, err = run_cli(*argv)
    assert status == 0, err
    assert (
        out.splitlines()[0].startswith("symladders atlas: 2 ED mesh(es) from")
        and "(random subset of 1), landmarks term, start the subset's first subject" in out
    )
    record = json.loads((tmp_path / "T.json").read_text())
    assert record["subset"]["rule"] == "random" and record["subset"]["seed"] == 3
    assert len(record["subjects"]) == 1 and record["start"] == record["subjects"][0]
    status, again, _ = run_cli(*argv)
    assert status == 0 and again.splitlines()[-1] == (
        f"symladders atlas: reused {tmp_path / 'T.vtk'}: finished before with the same inputs "
        f"and settings (key {record['key']}, 1 iteration(s)); --no-resume estimates it again"
    )
    status, fresh, _ = run_cli(*argv, "--no-resume", "--no-progress")
    assert status == 0 and "converged after 1" in fresh.splitlines()[-1]
    status, _, err = run_cli(*argv[:5], "--subset", "0")
    assert status == 2 and "--subset" in err
    status, _, _ = run_cli(*argv[:5], "--subset", "all", "--max-iter", "1", "-j", "1")
    record = json.loads((tmp_path / "T.json").read_text())
    assert status == 0 and record["subset"] is None and len(record["subjects"]) == 2
