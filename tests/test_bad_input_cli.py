"""Bad input on the ``symladders`` command line.

Every case runs :func:`ladders.study.cli.main` in-process (two through a
subprocess) and asserts exit status 2, exactly one line on standard error that
names the flag, and no traceback; an internal error exits with status 3 and
says where its traceback was logged.
"""

import subprocess
import sys

import pytest

from ladders.study.cli import main


def cli_cases():
    rows = [
        ("study --jobs 0", "--jobs"),
        ("study --jobs -2", "--jobs"),
        ("study --jobs many", "--jobs"),
        ("study --max-iter -3", "--max-iter"),
        ("study --max-iter 0", "--max-iter"),
        ("study --max-iter 1.5", "--max-iter"),
        ("study --fanning-steps 0", "--fanning-steps"),
        ("study --n-steps 0", "--n-steps"),
        ("study --sigma 0", "--sigma"),
        ("study --sigma -1", "--sigma"),
        ("study --sigma nan", "--sigma"),
        ("study --sigma inf", "--sigma"),
        ("study --sigma abc", "--sigma"),
        ("study --subjects 0", "--subjects"),
        ("study --subjects -1", "--subjects"),
        ("study --seed -1", "--seed"),
        ("study --vertices 0", "--vertices"),
        ("study -o {file}", "--output"),
        ("study -o {file}/sub", "--output"),
        ("study --meshes {tmp}/missing", "--meshes"),
        ("study --meshes {file}", "--meshes"),
        ("study --alpha2 abc", "--alpha2"),
        ("study --alpha2 -1", "--alpha2"),
        ("study --control-points bogus", "--control-points"),
        ("study --integrator bogus", "--integrator"),
        ("study --kernel-backend gpu", "--kernel-backend"),
        ("study --backend dask --scheduler tcp://127.0.0.1:1", "--scheduler"),
        ("study --backend dask --scheduler not-an-address", "--scheduler"),
        ("study --bogus", "--bogus"),
        ("study --units m", "--units"),
        ("study --allow-scale", "--allow-scale"),
        ("study --allow-pose", "--allow-pose"),
        ("study --units inch", "--units"),
        ("correspond", "--atlas"),
        ("correspond --atlas {mesh}", "--meshes"),
        ("correspond --atlas {tmp}/missing.vtk --meshes {empty}", "--atlas"),
        ("correspond --atlas {file} --meshes {empty}", "--atlas"),
        ("correspond --atlas {empty} --meshes {empty}", "--atlas"),
        ("correspond --atlas {badmesh} --meshes {empty} -o {tmp}/o", "--atlas"),
        ("correspond --atlas {mesh} --meshes {tmp}/missing", "--meshes"),
        ("correspond --atlas {mesh} --meshes {empty} -o {tmp}/o", "--meshes"),
        ("correspond --atlas {mesh} --meshes {noes} -o {tmp}/o", "--meshes"),
        ("correspond --atlas {mesh} --meshes {empty} -o {file}", "--output"),
        ("correspond --atlas {mesh} --meshes {empty} --jobs 0", "--jobs"),
        ("correspond --atlas {mesh} --meshes {empty} --units inch", "--units"),
        ("correspond --atlas {mesh} --meshes {empty} --sigma-w 0", "--sigma-w"),
        ("correspond --atlas {mesh} --meshes {empty} --weight abc", "--weight"),
        ("correspond --atlas {mesh} --meshes {empty} --weight -1", "--weight"),
        ("correspond --atlas {mesh} --meshes {empty} --ext vtp", "--ext"),
        ("correspond --atlas {mesh} --meshes {empty} --alignment affine", "--alignment"),
        ("correspond --atlas {mesh} --meshes {empty} --no-resum", "--no-resum"),
        ("atlas", "--meshes"),
        ("atlas --meshes {tmp}/missing", "--meshes"),
        ("atlas --meshes {empty} -o {tmp}/a.vtk", "--meshes"),
        ("atlas --meshes {noes} -o {tmp}/atlas.txt", "--output"),
        ("atlas --meshes {noes} -o {file}/a.vtk", "--output"),
        ("atlas --meshes {noes} -o {empty}", "--output"),
        ("atlas --meshes {noes} -o {tmp}/a.vtp", "--output"),
        ("atlas --meshes {noes} --tol 0", "--tol"),
        ("atlas --meshes {noes} --max-iter 0", "--max-iter"),
        ("atlas --meshes {noes} --term bogus", "--term"),
        ("atlas --meshes {noes} --units m3", "--units"),
        ("atlas --meshes {noes} -o {tmp}/a.vtk --start nobody", "--start"),
        ("atlas --meshes {noes} -o {tmp}/a.vtk --start mean --term varifold", "--start"),
        ("validate --seed -1", "--seed"),
        ("validate --seed abc", "--seed"),
        ("validate -o {file}", "--output"),
        ("validate -o {file}/sub", "--output"),
        ("bogus", "bogus"),
        ("", "command"),
        ("study --sigma 0.01 --subjects 1 --vertices 40 -o {tmp}/out", "sigma"),
    ]
    return [pytest.param(args, name, id=args or "no-command") for args, name in rows]


@pytest.fixture
def paths(tmp_path):
    """A file, an atlas, an unreadable mesh, an empty folder and one whose subjects have ED
    meshes only (in correspondence? no: the second is remeshed)."""
    from ladders.study import write_mesh
    from ladders.study.cohort import make_synthetic_cohort
    from ladders.study.preparation import remesh

    file = tmp_path / "a_file.txt"
    file.write_text("not a folder")
    c = make_synthetic_cohort(2, grid=(8, 5), seed=0)
    write_mesh(tmp_path / "atlas.vtk", c.atlas, c.faces)
    (tmp_path / "bad.vtk").write_text("# vtk DataFile but not really")
    for folder in ("empty", "noes"):
        (tmp_path / folder).mkdir()
    write_mesh(tmp_path / "noes" / "s1_ed.vtk", c.subjects[0].ed, c.faces)
    write_mesh(tmp_path / "noes" / "s2_ed.vtk", *remesh(c.subjects[1].ed, c.faces, 80))
    folders = {k: str(tmp_path / k) for k in ("empty", "noes")}
    return {"file": str(file), "tmp": str(tmp_path), "mesh": str(tmp_path / "atlas.vtk"),
            "badmesh": str(tmp_path / "bad.vtk"), **folders}  # fmt: skip


def one_line_error(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize(("args", "name"), cli_cases())
def test_cli_bad_input_is_one_line_with_status_2(args, name, paths, capsys):
    argv = args.format(**paths).split()
    assert main(argv) == 2
    line = one_line_error(capsys.readouterr().err)
    assert name in line and "error" in line


def test_cli_internal_error_is_reported_with_its_log(tmp_path, capsys, monkeypatch):
    import ladders.study.analytic_validation as av

    def broken(*args, **kwargs):
        raise RuntimeError("simulated failure")

    monkeypatch.setattr(av, "run_validation", broken)
    out = tmp_path / "out"
    assert main(["validate", "--quick", "-o", str(out)]) == 3
    line = one_line_error(capsys.readouterr().err)
    assert "internal error" in line and "simulated failure" in line
    log = out / "symladders-error.log"
    assert str(log) in line
    assert "RuntimeError: simulated failure" in log.read_text()


@pytest.mark.parametrize(
    "args", [["study", "--jobs", "0"], ["validate", "-o", "{file}"]], ids=["jobs", "output"]
)
def test_cli_bad_input_in_a_subprocess(args, paths):
    argv = [a.format(**paths) for a in args]
    proc = subprocess.run(
        [sys.executable, "-m", "ladders.study.cli", *argv],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    one_line_error(proc.stderr)
    assert proc.stdout == ""
