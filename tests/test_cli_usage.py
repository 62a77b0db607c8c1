"""What a new user meets on the command line: help texts, spelling, counts, pipes."""

import subprocess
import sys

import pytest

from ladders.study.cli import build_parser, main
from ladders.study.cohort import MissingAtlasError, make_synthetic_cohort, read_cohort, write_cohort

COHORT = make_synthetic_cohort(n_subjects=3, grid=(5, 3), seed=0)


def _help(*argv) -> str:
    with pytest.raises(SystemExit) as info:
        build_parser().parse_args([*argv, "--help"])
    assert info.value.code == 0
    return info


def test_more_subjects_than_the_folder_holds_stops_with_a_message(tmp_path, capsys):
    folder = write_cohort(COHORT, tmp_path / "m", ext="vtu")
    args = ["study", "--meshes", str(folder), "-o", str(tmp_path / "o"), "--no-progress"]
    assert main([*args, "--subjects", "5"]) == 2
    err = capsys.readouterr().err
    assert "--subjects 5: the --meshes folder holds only 3 subject(s)" in err
    assert not (tmp_path / "o" / "results").exists()  # nothing ran


def test_a_missing_atlas_is_named_by_the_flag_on_the_command_line(tmp_path, capsys):
    folder = write_cohort(COHORT, tmp_path / "m", ext="vtu")
    (folder / "atlas.vtu").unlink()
    with pytest.raises(MissingAtlasError, match=r"no atlas file .*; name one with atlas=PATH$"):
        read_cohort(folder)  # the API's spelling
    assert main(["study", "--meshes", str(folder), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.strip().endswith("name one with --atlas PATH") and "atlas=PATH" not in err


@pytest.mark.parametrize(
    ("typed", "meant"),
    [("stduy", "study"), ("valdate", "validate"), ("corespond", "correspond"), ("atlsa", "atlas")],
)
def test_a_mistyped_subcommand_is_answered_with_the_closest(typed, meant, capsys):
    assert main([typed]) == 2
    err = capsys.readouterr().err
    assert f"unknown command '{typed}'; did you mean '{meant}'?" in err
    assert f"symladders {meant} --help" in err and "usage" not in err
    assert main(["xyz"]) == 2
    err = capsys.readouterr().err
    assert (
        "unknown command 'xyz', choose from run, study, mesh, correspond, atlas, cohort, "
        "analyze, validate" in err
    )


def test_options_are_not_abbreviated(tmp_path, capsys):
    folder = write_cohort(COHORT, tmp_path / "m", ext="vtu")
    assert main(["study", "--mesh", str(folder), "-o", str(tmp_path / "o")]) == 2
    assert "unrecognized arguments: --mesh" in capsys.readouterr().err


def test_help_texts_show_each_default_once(capsys):
    _help("study")
    text = " ".join(capsys.readouterr().out.split())
    assert "--integrator {euler,rk2,rk4} time integrator of the flows" in text
    assert "(default: euler)" in text
    assert "default: None" not in text and "default: False" not in text
    subjects = text[text.index("--subjects SUBJECTS number") : text.index("--full the paper")]
    assert subjects.count("default") == 1 and "20 of the built-in cohort" in subjects
    _help("validate")
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: symladders-output/validation)" in text and "(default: 0)" in text


@pytest.mark.parametrize("command", ["correspond", "atlas"])
def test_the_preparation_commands_show_each_default_once_and_help_every_flag(command, capsys):
    from ladders.study.preparation import CorrespondenceSettings

    _help(command)
    text = " ".join(capsys.readouterr().out.split())
    assert "default: None" not in text and "default: False" not in text
    assert f"(default: {CorrespondenceSettings().sigma_w})" in text  # the library's
    assert "(default: landmarks)" in text
    parser = next(a for a in build_parser()._actions if a.dest == "command").choices[command]
    for action in parser._actions:
        assert action.help, action.option_strings  # every flag is explained
    for flag in ("--start", "--ext"):  # defaults given in words
        help_ = next((a.help for a in parser._actions if flag in a.option_strings), None)
        if help_ is not None:
            assert help_.count("default") == 1


def test_the_vertices_default_is_the_count_the_built_in_meshes_have():
    args = build_parser().parse_args(["study"])
    assert args.vertices == make_synthetic_cohort(1, n_vertices=args.vertices).n_vertices == 1009
    assert make_synthetic_cohort(1).n_vertices == 1009


@pytest.mark.parametrize(
    "argv",
    [["study", "--help"], ["study", "--subjects", "1", "--vertices", "25", "--no-progress"]],
    ids=["help", "study"],
)
def test_a_closed_pipe_ends_quietly(argv, tmp_path):
    """``symladders study | head``: no error message, the status of a SIGPIPE."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "ladders.study.cli",
            *argv,
            *(["-o", str(tmp_path)] * (len(argv) > 2)),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # the reader goes away before the command writes anything
    err = proc.stderr.read()
    status = proc.wait(timeout=120)
    assert err == b""
    # argparse's help ignores the closed pipe itself; the study stops at its first line.
    assert status == (0 if "--help" in argv else 141)
    assert not list(tmp_path.glob("results/*/*/*.json"))
