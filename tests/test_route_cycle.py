"""``symladders run`` through the whole cycle: series tracked, transported, tested, and the wall.

``symladders cohort --cycle`` writes the whole-cycle cohort as a user holds it: 4-D label
series (blood pool, myocardium, right ventricle), ``subjects.csv`` with group, age, sex
and body size, and ``study.toml`` naming the three labels. The route runs on eight
subjects of six frames (small meshes, one atlas iteration, few permutations: the
settings only make it quick) and every step of the cycle runs: tracking with the
epicardium, the cycle study, the cycle's model, the wall maps and the model on the
wall's thickening. The planted hypokinesia (segments 7, 8, 13, 14) lowers the patients'
peak inward motion there: the segments' peak statistics are negative, and lower than
the other segments'.
"""

import csv

import numpy as np
import pytest

from tests.cli_runner import run_cli
from tests.tutorial_tree import CYCLE_FOLDERS, TUTORIAL, missing, tree_of_the_tutorial

PLANTED = {7, 8, 13, 14}
QUICK = """vertices = 300

[atlas]
max_iter = 1
"""


@pytest.fixture(scope="module")
def cycle_route(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cycle_route")
    status, out, err = run_cli("cohort", "--cycle", "6", "--subjects", "8", "--vertices", "300",
                               "--age-effect", "0.1", "-o", folder, "--no-progress")  # fmt: skip
    assert status == 0, err
    settings = folder / "study.toml"
    text = settings.read_text(encoding="utf-8")
    assert "myocardium_label = 2" in text and "rv_label = 3" in text
    text = text.replace("myocardium_label = 2", "myocardium_label = 2\n" + QUICK.split("\n\n")[0])
    settings.write_text(text + "permutations = 200\n\n" + QUICK.split("\n\n")[1], encoding="utf-8")
    return folder, run_cli("run", settings)


def _rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def test_every_step_of_the_cycle_runs(cycle_route):
    folder, (status, out, err) = cycle_route
    assert status == 0, out[-3000:] + err[-3000:]
    ran = [line.split("] ")[1].split(":")[0] for line in out.splitlines() if line.startswith("[")]
    assert ran == ["mesh", "atlas", "correspond", "track", "study", "analysis", "cycle-study",
                   "cycle-analysis", "wall", "wall-analysis", "report"]  # fmt: skip
    results = folder / "study_results"
    report = (results / "report.md").read_text(encoding="utf-8")
    for heading in ("## The whole cycle", "## The wall's thickening", "## The subjects"):
        assert heading in report
    for link in [part.split(")")[0] for part in report.split("](")[1:]]:
        assert (results / link).is_file(), link
    for name in ("cycle_analysis", "wall_analysis"):
        design = _rows(results / name / "design.csv")
        assert len(design) == 8 and set(design[0]) == {
            "subject",
            "group",
            "age",
            "sex",
            "body_size",
        }
    epicardia = sorted((results / "tracked" / "synthetic_000" / "epicardium").glob("frame_*.vtk"))
    assert len(epicardia) == 6


def test_the_planted_segments_lose_peak_motion(cycle_route):
    folder, _ = cycle_route
    rows = [r for r in _rows(folder / "study_results" / "cycle_analysis" / "cycle_segments.csv")
            if r["summary"] == "peak"]  # fmt: skip
    t = {int(r["segment"]): float(r["statistic"]) for r in rows}
    planted = np.mean([t[s] for s in PLANTED])
    others = np.mean([t[s] for s in t if s not in PLANTED])
    assert planted < 0 and planted < others - 1.0, t


def test_the_tutorial_names_what_the_cycle_wrote(cycle_route):
    """Every file and folder of the whole cycle and the wall docs/tutorial_own_data.md says
    the route writes, it wrote."""
    folder, _ = cycle_route
    expected = [p for p in tree_of_the_tutorial() if p.startswith((*CYCLE_FOLDERS, "tracked/"))]
    assert "wall_analysis/" in expected and "cycle_study/*.npz" in expected
    absent = missing(folder / "study_results", expected)
    assert not absent, f"named in {TUTORIAL.name} but not written by the route: {absent}"
