"""``symladders run``: a synthetic cohort written as a user holds it, through the one command.

The cohort (``symladders cohort --images labels``' writer) has covariates acting on the
motion (age, sex, body size), label images with a right-ventricle label, one subject
given as a 4-D series (tracked through it) and one whose images hold no left ventricle
(it fails at the meshing and must not stop the others). The route runs once; the tests
read what it wrote: the plan parses with the real parser, every step wrote its folder,
the failing subject is reported with its step and reason, the design holds the
covariates of the subjects that reached the study, a rerun reuses every step, and a
changed covariate reruns the analysis alone.
"""

import csv
import json
import shlex

import nibabel as nib
import numpy as np
import pytest

from ladders.study.cli import build_parser
from tests.cli_runner import run_cli
from tests.tutorial_tree import CYCLE_FOLDERS, TUTORIAL, missing, tree_of_the_tutorial

N_PER_GROUP = 4
#: The cohort's settings with options that make it quick (smaller meshes, one atlas
#: iteration, fewer permutations).
SETTINGS = """subjects = "subjects.csv"

[images]
label = 1
rv_label = 3
vertices = 300

[atlas]
max_iter = 1

[model]
permutations = 100
truth = "planted_region.json"
"""


def _series(folder, subject):
    """A 4-frame series ED, ES, ES, ED of a subject's two images (the subject then has a row
    with ``image`` and ``es_frame`` 1 instead of its two 3-D images)."""
    ed = nib.load(str(folder / "images" / f"{subject}_ed.nii.gz"))
    es = nib.load(str(folder / "images" / f"{subject}_es.nii.gz"))
    frames = [np.asanyarray(x.dataobj) for x in (ed, es, es, ed)]
    img = nib.Nifti1Image(np.stack(frames, axis=3).astype(np.int16), ed.affine)
    nib.save(img, str(folder / "series" / f"{subject}.nii.gz"))
    return f"series/{subject}.nii.gz"


@pytest.fixture(scope="module")
def route(tmp_path_factory):
    from ladders.study.population import Covariates, make_covariate_cohort
    from ladders.study.population.image_cohort import write_image_cohort

    folder = tmp_path_factory.mktemp("route")
    data = make_covariate_cohort(N_PER_GROUP, covariates=Covariates(imbalance=0.5), seed=3)
    write_image_cohort(data, folder, spacing=2.5)
    (folder / "series").mkdir()
    with open(folder / "subjects.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    header = rows[0] + ["es_frame"]
    rows = [r + [""] for r in rows[1:]]
    rows[0][1:4] = [_series(folder, rows[0][0]), "", ""]
    rows[0][-1] = "1"
    empty = nib.Nifti1Image(np.zeros((8, 8, 8), np.int16), np.eye(4))  # no left ventricle
    for phase in ("ed", "es"):
        nib.save(empty, str(folder / "images" / f"broken_{phase}.nii.gz"))
    rows.append(["broken", "", "images/broken_ed.nii.gz", "images/broken_es.nii.gz",
                 *rows[1][4:-1], ""])  # fmt: skip
    with open(folder / "subjects.csv", "w", newline="", encoding="utf-8") as fh:
        csv.writer(fh, lineterminator="\n").writerows([header, *rows])
    settings = folder / "study.toml"
    written = settings.read_text(encoding="utf-8")
    assert 'subjects = "subjects.csv"' in written and "rv_label = 3" in written
    settings.write_text(SETTINGS, encoding="utf-8")
    dry = run_cli("run", settings, "--dry-run")
    first = run_cli("run", settings)
    second = run_cli("run", settings)
    return folder, data, dry, first, second


def test_the_plan_is_commands_the_parser_takes(route, monkeypatch):
    folder, _, (status, out, err), _, _ = route
    monkeypatch.chdir(folder / "study_results")  # the plan's paths are relative to it
    assert status == 0, err
    commands = [line.strip() for line in out.splitlines() if line.strip().startswith("symladders ")
                and not line.startswith("symladders run")]  # fmt: skip
    assert [shlex.split(c)[1] for c in commands] == [
        "mesh", "atlas", "correspond", "track", "study", "analyze", "cycle-study"]  # fmt: skip
    parser = build_parser()
    for command in commands:
        words = shlex.split(command)[1:]
        if words[0] == "mesh":  # the glob of the images folder, as a shell would expand it
            words[1:2] = sorted(str(p) for p in (folder / "study_results" / "inputs" /
                                                 "images").iterdir())  # fmt: skip
        parser.parse_args(words)  # raises on an unknown flag or a bad value


def test_the_route_runs_and_reports_the_failing_subject(route):
    folder, data, _, (status, out, err), _ = route
    assert status == 1, out + err  # one subject failed, the others went on
    results = folder / "study_results"
    for name in ("meshes", "atlas", "corresponded", "tracked", "study", "analysis",
                 "cycle_study", "logs"):  # fmt: skip
        assert (results / name).is_dir(), name
    report = (results / "report.md").read_text(encoding="utf-8")
    for heading in ("## What was found", "## The subjects", "## The steps", "## The settings",
                    "## Versions"):  # fmt: skip
        assert heading in report
    row = next(line for line in report.splitlines() if line.startswith("| broken |"))
    assert "| mesh |" in row and "label 1" in row, row
    for link in [part.split(")")[0] for part in report.split("](")[1:]]:
        assert (results / link).is_file(), link  # every figure the report shows exists
    with open(results / "analysis" / "design.csv", newline="", encoding="utf-8") as fh:
        design = list(csv.DictReader(fh))
    names = data.cohort.names
    assert [r["subject"] for r in design] == names
    assert set(design[0]) == {"subject", "group", "age", "sex", "body_size"}
    for r in design:
        assert float(r["age"]) == data.covariates[r["subject"]]["age"]
    assert "power" in report and "Dice" in report  # scored against the planted truth


def test_the_series_is_tracked_and_its_cycle_transported(route):
    folder, data, *_ = route
    results = folder / "study_results"
    subject = data.cohort.names[0]
    frames = sorted((results / "tracked" / subject).glob("frame_*.vtk"))
    assert len(frames) == 4
    assert (results / "cycle_study" / f"{subject}.npz").is_file()
    record = json.loads((results / "tracked" / f"{subject}.json").read_text(encoding="utf-8"))
    assert "closed" in record["estimated_planes"]["skipped"]  # no valve plane cut its meshes
    meshing = {r["mesh"]: r for r in csv.DictReader(open(results / "meshes" / "meshing.csv"))}
    assert meshing[f"{subject}_es.vtk"]["frame"] == "1"  # the table's ES frame


def test_a_second_run_reuses_every_step(route):
    folder, _, _, _, (status, out, err) = route
    assert status == 1, out + err  # the failed subject is still reported
    steps = [line for line in out.splitlines() if line.startswith("[")]
    assert steps and all(": reused (" in line for line in steps), out


def test_a_changed_covariate_reruns_the_analysis_alone(route, tmp_path):
    folder, *_ = route
    table = folder / "subjects.csv"
    text = table.read_text(encoding="utf-8")
    rows = list(csv.reader(text.splitlines()))
    age = rows[0].index("age")
    rows[2][age] = str(float(rows[2][age]) + 1.0)
    try:
        with open(table, "w", newline="", encoding="utf-8") as fh:
            csv.writer(fh, lineterminator="\n").writerows(rows)
        status, out, err = run_cli("run", folder / "study.toml")
    finally:
        table.write_text(text, encoding="utf-8")
    ran = [line.split(":")[0].split("] ")[1] for line in out.splitlines()
           if line.startswith("[") and ": reused (" not in line]  # fmt: skip
    assert ran == ["analysis", "report"], out
    record = json.loads((folder / "study_results" / "run.json").read_text(encoding="utf-8"))
    assert record["steps"]["mesh"]["status"] == "partial"


def test_the_tutorial_names_what_the_route_wrote(route):
    """Every file and folder of the ED-ES steps docs/tutorial_own_data.md says the route
    writes, it wrote (the whole cycle's and the wall's: test_route_cycle.py)."""
    folder, *_ = route
    expected = [p for p in tree_of_the_tutorial() if not p.startswith(CYCLE_FOLDERS)]
    assert "analysis/model_vertices.csv" in expected and "tracked/*/frame_*.vtk" in expected
    absent = missing(folder / "study_results", expected)
    assert not absent, f"named in {TUTORIAL.name} but not written by the route: {absent}"


def test_the_report_reads_each_study_once(route, monkeypatch):
    """A rerun of the report reads the study's results once for the analysis's design and
    once for the report, not once per subject."""
    from ladders.study.route import route_report

    folder, *_ = route
    calls = []
    real = route_report.subjects_with_results
    monkeypatch.setattr(route_report, "subjects_with_results",
                        lambda path: calls.append(path) or real(path))  # fmt: skip
    status, out, err = run_cli("run", folder / "study.toml", "--redo", "report")
    assert status in (0, 1), out + err
    assert (folder / "study_results" / "report.md").is_file()
    studies = [p for p in calls if p.name == "study"]  # the design's read and the report's
    assert len(studies) <= 2, f"the study folder read {len(studies)} times"
