"""One convention across the ``symladders`` commands, checked on the real parser.

Every option has help, and its help shows its default; an option name means one thing
and takes one format wherever it appears (type, nargs, metavar, choices, action); the
options of :mod:`ladders.study.cli.common_arguments` are the same in every command (help
and default too); every command that runs a batch of subjects or images takes the batch
flags. Differences are listed below, each with its reason.
"""

import argparse

import pytest

from ladders.study.cli.cli_types import DefaultsFormatter
from ladders.study.cli.entry import build_parser

#: Options defined once in common_arguments: the same help and default everywhere.
SHARED = ("--jobs", "--no-progress", "--backend", "--scheduler", "--seed", "--permutations",
          "--compare", "--cut-planes")  # fmt: skip
#: The commands that run a batch of subjects or images, and the flags they all take.
BATCH_COMMANDS = ("mesh", "correspond", "atlas", "track", "study", "cycle-study")
BATCH_FLAGS = ("--jobs", "--no-progress", "--backend", "--scheduler")

#: (option, command): why its format differs from the option's in the other commands.
EXCEPTIONS = {
    (
        "--alpha2",
        "cycle-study",
    ): "one alpha^2 per cycle study: a number, the first form of A[,B...]",
    ("--output", "atlas"): "the atlas is one mesh file (FILE), the others write folders",
    ("--design", "cohort"): "a switch: cohort writes design.csv, the table analyze --design reads",
    ("--landmarks", "cohort"): "a switch: cohort writes landmarks.csv, the table correspond and "
    "atlas --landmarks read",
    ("--vertices", "mesh"): "a decimation target (0: no decimation); study and cohort build "
    "meshes of N >= 1 vertices",
    ("--vertices", "track"): "as mesh's: the decimation target of every frame's surface",
    ("--deformation", "study"): "the study runs and compares several models, NAME[,NAME...] "
    "('both': lddmm,svf); cycle-study and validate run one",
}
#: Options waiting for their shared definition (none now).
PENDING: set = set()


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


COMMANDS = _commands()


def _options(parser):
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        name = max(action.option_strings, key=len) if action.option_strings else action.dest
        yield name, action


def _form(action) -> tuple:
    kind = getattr(action.type, "__name__", action.type)
    choices = None if action.choices is None else tuple(sorted(map(str, action.choices)))
    return (type(action).__name__, kind, action.nargs, action.metavar, choices,
            tuple(sorted(action.option_strings)))  # fmt: skip


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_option_has_help_that_shows_its_default(command):
    parser = COMMANDS[command]
    assert issubclass(parser.formatter_class, DefaultsFormatter)
    formatter = parser._get_formatter()
    for name, action in _options(parser):
        if (name, command) in PENDING:
            continue
        assert action.help and action.help.strip(), f"{command} {name}: no help"
        shown = formatter._get_help_string(action)
        if action.default not in (None, False, argparse.SUPPRESS) and not action.required:
            assert "%(default)" in shown, f"{command} {name}: the help does not show its default"
            assert f"default: {action.default}" not in action.help, f"{command} {name}: twice"
    parser.format_help()  # every help string expands


def test_an_option_has_one_format_and_the_shared_ones_one_help_and_default():
    seen: dict[str, dict[str, argparse.Action]] = {}
    for command, parser in COMMANDS.items():
        for name, action in _options(parser):
            if action.option_strings:
                seen.setdefault(name, {})[command] = action
    assert set(SHARED) <= set(seen)
    for name, actions in seen.items():
        usual = {c: a for c, a in actions.items()
                 if (name, c) not in EXCEPTIONS and (name, c) not in PENDING}  # fmt: skip
        forms = {c: _form(a) for c, a in usual.items()}
        assert len(set(forms.values())) <= 1, f"{name} differs between commands: {forms}"
        if name in SHARED:
            helps = {(a.help, repr(a.default)) for a in usual.values()}
            assert len(helps) == 1, f"{name}: help or default differs: {helps}"
    for name, command in EXCEPTIONS:  # an exception that no longer differs is removed
        others = {
            _form(a) for c, a in seen[name].items() if c != command and (name, c) not in EXCEPTIONS
        }
        assert _form(seen[name][command]) not in others, f"{name} {command}: not an exception"


@pytest.mark.parametrize("command", BATCH_COMMANDS)
def test_every_batch_command_takes_the_batch_flags(command):
    names = {name for name, _ in _options(COMMANDS[command])}
    assert set(BATCH_FLAGS) <= names
    args = COMMANDS[command]._defaults
    assert callable(args["run"])


def test_cohort_takes_no_progress():
    assert "--no-progress" in {name for name, _ in _options(COMMANDS["cohort"])}
