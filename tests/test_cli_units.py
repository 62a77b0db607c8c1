"""Units and pose in ``symladders study``: checked before any registration, stated in the outputs."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

import ladders.study.cli.study_cli as study_cli
from ladders.study.cohort import Cohort, Subject, make_synthetic_cohort, write_cohort

from .cli_runner import run_cli

COHORT = make_synthetic_cohort(n_subjects=2, grid=(8, 5), seed=0)
RUN = ["--alpha2", "1089", "--sigma", "20", "--max-iter", "30", "--fanning-steps", "2",
       "--no-progress", "--no-meshes", "-j", "1"]  # fmt: skip


def moved(transform) -> Cohort:
    """The cohort with the second subject's meshes moved by ``transform``."""
    a, b = COHORT.subjects
    return Cohort(
        COHORT.atlas, COHORT.faces, [a, Subject(b.name, transform(b.ed), transform(b.es))]
    )


def test_a_subject_in_metres_stops_the_study_until_its_unit_is_given(tmp_path):
    folder = write_cohort(moved(lambda v: v / 1000), tmp_path / "m", ext="ply")
    status, out, err = run_cli("study", "--meshes", folder, "-o", tmp_path / "o", *RUN)
    assert status == 2 and out == "" and len(err.splitlines()) == 1
    assert err.startswith("symladders study: error: --meshes: 2 mesh(es) disagree(s) in size")
    assert f"{COHORT.names[1]}:ed: size" in err and "likely in m" in err and "--units" in err
    assert not (tmp_path / "o").exists()
    status, out, err = run_cli("study", "--meshes", folder, "-o", tmp_path / "o", "--units",
                               "auto", *RUN)  # fmt: skip
    assert status == 0, err
    stated = f"Converted to mm: {COHORT.names[1]} (from m)."
    assert stated in out and stated in (tmp_path / "o" / "summary.md").read_text()
    units = json.loads((tmp_path / "o" / "manifest.json").read_text())["data"]["units"]
    assert units["how"] == "detected" and units["factors"][COHORT.names[1]] == 1000.0


def test_the_built_in_cohort_is_in_mm(tmp_path):
    status, _, err = run_cli("study", "--subjects", "1", "--vertices", "40", "-o", tmp_path, *RUN)
    assert status == 0, err
    assert (
        "Lengths in mm, the built-in synthetic cohort's unit."
        in (tmp_path / "summary.md").read_text()
    )
    units = json.loads((tmp_path / "manifest.json").read_text())["data"]["units"]
    assert units == {"unit": "mm", "how": "built-in"}


@pytest.fixture
def checked(monkeypatch):
    """The cohort and the units sentence each study would run with (nothing runs)."""
    seen = []

    def fake_run(args, cohort, description, config, output, units):
        seen.append((cohort, units, description["units"]))
        return SimpleNamespace(failures=[])

    monkeypatch.setattr(study_cli, "_run_one", fake_run)
    return seen


def test_a_far_pose_is_refused_unless_allowed(tmp_path, checked):
    folder = write_cohort(moved(lambda v: v + [300.0, 0.0, 0.0]), tmp_path / "m", ext="vtk")
    status, _, err = run_cli("study", "--meshes", folder, "-o", tmp_path / "o", *RUN)
    assert status == 2 and "far from the atlas's pose" in err and "--allow-pose" in err
    assert checked == []
    assert run_cli("study", "--meshes", folder, "-o", tmp_path / "o", "--allow-pose", *RUN)[0] == 0
    ((cohort, units, record),) = checked
    assert f"Poses far from the atlas's, accepted: {COHORT.names[1]}:ed" in units
    np.testing.assert_array_equal(cohort.subjects[1].ed, COHORT.subjects[1].ed + [300.0, 0, 0])
    assert record["pose_checked"] is False


def test_a_unit_given_converts_every_subject(tmp_path, checked):
    table = write_cohort(COHORT, tmp_path / "t", ext="vtk")
    status, _, err = run_cli("study", "--meshes", table, "-o", tmp_path / "o", "--units", "mm",
                             *RUN)  # fmt: skip
    assert status == 0, err
    assert "the subjects' unit was given as mm" in checked[0][1]
    status, _, err = run_cli("study", "--meshes", table, "-o", tmp_path / "o", "--units", "cm",
                             *RUN)  # fmt: skip
    assert status == 2 and "disagree(s) in size" in err  # 10 times the atlas's size
    status, _, err = run_cli("study", "--meshes", table, "-o", tmp_path / "o", "--units", "cm",
                             "--allow-scale", *RUN)  # fmt: skip
    assert status == 0 and checked[-1][2]["factors"][COHORT.names[0]] == 10.0
    np.testing.assert_allclose(checked[-1][0].subjects[0].es, 10 * COHORT.subjects[0].es)
