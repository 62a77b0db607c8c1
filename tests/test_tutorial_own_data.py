"""The own-data tutorial runs: its command block, from label images to the p-value map.

The fenced block after ``<!-- tutorial-commands -->`` in ``docs/tutorial_own_data.md``
is run as written, command by command, through the CLI entry point, from a scratch
folder that holds what the tutorial asks for: ``images/`` (label images of six
subjects of the synthetic two-group cohort, 2.5 mm voxels, LV label 1, RV label 2),
``planes.csv`` and ``groups.csv`` (written by ``benchmarks/bench_tutorial.py``, which
times the same block). The only change is :data:`FAST`: options appended to the
command of that name to make it quick. ``argparse`` keeps the last value of an
option, so an appended option overrides the page's; none of the key options of the
tutorial is among them (checked below).
"""

import csv
import importlib.util
import shlex
import time
from pathlib import Path

import meshio
import numpy as np
import pytest

from ladders.study import read_mesh

ROOT = Path(__file__).resolve().parents[1]

#: Options appended to each command for speed (the page's own options are kept).
FAST = {
    "mesh": ["--vertices", "300", "--jobs", "2", "--no-progress"],
    "atlas": ["--max-iter", "1", "--no-progress"],
    "correspond": ["-j", "2", "--no-progress"],
    "study": ["--sigma", "20", "--max-iter", "200", "--no-meshes", "-j", "2", "--no-progress"],
    "analyze": ["--permutations", "200", "--no-progress"],
}
#: Options of the tutorial that the test must run as written.
KEY_OPTIONS = {
    "mesh": ["--label", "--rv-label", "--cut-planes", "-o"],
    "atlas": ["--meshes", "-o"],
    "correspond": ["--atlas", "--meshes", "-o"],
    "study": ["--meshes", "--alpha2", "-o"],
    "analyze": ["--groups"],
}
N_SUBJECTS = 6


def _bench():
    spec = importlib.util.spec_from_file_location(
        "bench_tutorial", ROOT / "benchmarks" / "bench_tutorial.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The block run once on the synthetic label images: folder, commands, outcomes."""
    bench = _bench()
    commands = bench.tutorial_commands(ROOT / "docs" / "tutorial_own_data.md")
    work = tmp_path_factory.mktemp("own_data")
    data, names = bench.write_image_cohort(work, N_SUBJECTS, spacing=2.5, n_vertices=241)
    outcomes = []
    for command in commands:
        start = time.perf_counter()
        status, out, err = bench.run_command(command, work, FAST.get(command[1], []))
        outcomes.append((command, status, out, err, time.perf_counter() - start))
        if status != 0:
            break
    return work, commands, outcomes, data, names


def test_the_block_is_the_documented_sequence(run):
    _, commands, _, _, _ = run
    assert [c[0] for c in commands] == ["symladders"] * 5
    assert [c[1] for c in commands] == ["mesh", "atlas", "correspond", "study", "analyze"]
    for command in commands:
        for option in KEY_OPTIONS[command[1]]:
            assert option in command, f"{shlex.join(command)} lacks {option}"
            assert option not in FAST[command[1]], f"FAST overrides {option}"
    mesh, study = commands[0], commands[3]
    assert mesh[mesh.index("--cut-planes") + 1] == "planes.csv"
    assert mesh[mesh.index("--label") + 1] != mesh[mesh.index("--rv-label") + 1]
    assert float(study[study.index("--alpha2") + 1]) >= 10  # a large alpha^2 for groups


def test_every_command_succeeds(run):
    _, commands, outcomes, _, _ = run
    for command, status, out, err, _ in outcomes:
        assert status == 0, f"{shlex.join(command)} exited {status}:\n{out[-2000:]}\n{err[-2000:]}"
    assert len(outcomes) == len(commands)


def test_the_meshes_are_cut_at_the_valve_planes_and_have_landmarks(run):
    work, _, _, data, names = run
    with open(work / "meshes" / "meshing.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * N_SUBJECTS and {r["status"] for r in rows} == {"ok"}
    assert all("open (1 boundary loop(s))" in r["report"] for r in rows)
    with open(work / "meshes" / "landmarks.csv") as fh:
        subjects = {r["subject"] for r in csv.DictReader(fh)}
    assert subjects == set(names.values())
    assert (work / "atlas_landmarks.csv").is_file()


def test_the_p_value_map_has_one_value_per_atlas_vertex(run):
    work, _, _, _, _ = run
    atlas_vertices, _ = read_mesh(work / "corresponded" / "atlas.vtk")
    analysis = work / "study" / "analysis"  # the default STUDY_OUTPUT/analysis
    maps = meshio.read(analysis / "maps" / "lddmm_pole_ladder_residual_alpha2=100.vtu")
    assert len(maps.points) == len(atlas_vertices)
    np.testing.assert_allclose(maps.points, atlas_vertices, atol=1e-6)
    for field in ("normal_p_fwer", "wall_motion_p_fwer", "hotelling_p_fwer", "strain_p_fwer"):
        p = np.asarray(maps.point_data[field])
        assert p.shape == (len(atlas_vertices),), field
        assert np.isfinite(p).all() and (p >= 0).all() and (p <= 1).all(), field
    summary = (analysis / "summary.md").read_text(encoding="utf-8")
    assert "controls (3) against patients (3)" in summary
    assert (analysis / "fig_pvalue_map.png").read_bytes()[:4] == b"\x89PNG"


def test_the_groups_are_those_of_the_table(run):
    work, _, _, data, names = run
    with open(work / "groups.csv") as fh:
        table = {r["subject"]: r["group"] for r in csv.DictReader(fh)}
    assert table == {names[k]: g for k, g in data.groups.items()}
    with open(work / "study" / "analysis" / "tests.csv") as fh:
        assert len(list(csv.DictReader(fh))) == 4  # no transport and three transports
