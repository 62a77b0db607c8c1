"""Every ``symladders ...`` command written in the docs parses with the real parser.

Found in README.md, docs/*.md and examples/: the lines of code blocks (fenced, except
Python, and indented; continued lines joined; shell comments, pipes and ``&&`` handled)
and the inline code spans of prose and tables. Nothing runs: each line is parsed by
:func:`ladders.study.cli.entry.build_parser`, and an unknown command or flag, a wrong value
or (in a code block) a missing argument fails. The rules for what docs write instead of
real values:

* a file or folder is not looked for: its argument is checked for its form only (the
  ``syntax`` of the argparse types that look at the file system or the network:
  :func:`ladders.study.cli.cli_types.checks_files`);
* a placeholder in capitals (``STUDY_OUTPUT``, ``DIR``, ``A,B``, ``ED,ES``, ``MM``) or
  ``...`` stands for any value of its argument; a ``...`` that follows no option stands
  for more options and is dropped;
* a synopsis's brackets (``[--compare A,B]``) are dropped and each of its alternatives
  (``--units auto|mm|cm``) is parsed;
* an inline span names a command and some of its flags: its required arguments may be
  left out, and so may the value of its last flag (``symladders track --cut-planes``);
* ``symladders <command>: ...`` is the command's output, not a command;
* :data:`SHOWN_WRONG`: the commands the docs show failing, which must fail.
"""

import argparse
import re
import shlex
from pathlib import Path

import pytest

from ladders.study.cli.cli_types import UsageError
from ladders.study.cli.entry import build_parser

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted(p.relative_to(ROOT).as_posix()
               for p in [ROOT / "README.md", *ROOT.glob("docs/*.md"), *ROOT.glob("examples/*")]
               if p.is_file())  # fmt: skip

#: Commands the docs show failing on purpose (a mistyped command and its answer).
SHOWN_WRONG = {"symladders stduy"}

_PLACEHOLDER = re.compile(r"^(\.\.\.|[A-Z][A-Z0-9_]*(?:[,.][A-Z0-9_]+)*(?:\.\.\.)?)$")
_SHELL = {"|", "||", "&&", ";", ">", ">>", "2>", "&"}


def commands_of(text: str) -> list[tuple[int, str, bool]]:
    """``(line, command, inline)`` of every ``symladders`` command of a page's text."""
    found, fence, lines = [], None, text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        start = i + 1
        if line.lstrip().startswith("```"):
            fence = None if fence is not None else line.strip()[3:].strip() or "text"
            i += 1
            continue
        code = (fence is not None and fence != "python") or (
            fence is None and line.startswith("    ")
        )
        while code and line.rstrip().endswith("\\") and i + 1 < len(lines):
            i += 1
            line = line.rstrip()[:-1] + " " + lines[i].strip()
        if code:
            found.extend((start, c, False) for c in _shell_commands(line))
        elif fence is None:
            for span in re.findall(r"`(symladders [^`]*)`", line):
                found.extend((start, c, True) for c in _shell_commands(span) or [span])
        i += 1
    return found


def _shell_commands(line: str) -> list[str]:
    """The ``symladders ...`` commands of a shell line (after ``$``, environment
    assignments, ``&&``, ``;``; up to a pipe or a redirection; comments dropped)."""
    text = line.strip().removeprefix("$ ").removeprefix("# ")
    if "symladders " not in text:
        return []
    try:
        tokens = shlex.split(text, comments=True)
    except ValueError:
        return []
    out, segment, depth = [], [], 0
    for token in [*tokens, ";"]:
        if token in _SHELL and not (token == "|" and depth > 0):  # '[A | B]': alternatives
            depth = 0
            words = [w for w in segment if not re.match(r"^[A-Z_]+=", w)]
            if words[:1] == ["symladders"] and len(words) > 1:
                out.append(shlex.join(words))
            segment = []
        else:
            segment.append(token)
            depth += token.count("[") - token.count("]")
    return out


def _command_parsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return parser, sub.choices


def _lenient(value_of_choices, syntax):
    def check(text):
        if _PLACEHOLDER.match(text):  # any value: a choice's, or the text itself
            return text if value_of_choices is None else value_of_choices
        return syntax(text)

    return check


def _prepare(parser, subparsers, inline: bool):
    """Types checked for their form only, placeholders accepted; for inline spans, no
    argument required."""
    for command in subparsers.values():
        for action in command._actions:
            if isinstance(action, argparse._HelpAction) or action.nargs == 0:
                continue
            syntax = getattr(action.type, "syntax", action.type) or str
            first = next(iter(action.choices)) if action.choices else None
            action.type = _lenient(first, syntax)
            if inline:
                action.required = False
                if not action.option_strings:
                    action.nargs = "*" if action.nargs in ("+", "*") else "?"
    return parser


PARSERS = {inline: _prepare(*_command_parsers(), inline) for inline in (False, True)}


def _alternatives(tokens: list[str]) -> list[list[str]]:
    """A synopsis's ``[A ... | B ...]`` as one command with ``A ...`` and one with ``B ...``."""
    if "|" not in tokens:
        return [tokens]
    k = tokens.index("|")
    start = max(i for i in range(k) if "[" in tokens[i])
    end = min(i for i in range(k, len(tokens)) if "]" in tokens[i])
    left = [*tokens[:k], *tokens[end + 1 :]]
    right = [*tokens[:start], *tokens[k + 1 :]]
    return [*_alternatives(left), *_alternatives(right)]


def _variants(tokens: list[str]) -> list[list[str]]:
    """The command without a synopsis's brackets, once per alternative (``[A | B]``, and
    ``a|b`` within a token)."""
    return [v for alternative in _alternatives(tokens) for v in _value_variants(alternative)]


def _value_variants(tokens: list[str]) -> list[list[str]]:
    tokens = [t.replace("[", "").replace("]", "") for t in tokens]
    tokens = [t for t in tokens if t]
    variants = [[t.split("|")[0] if "|" in t else t for t in tokens]]
    for i, token in enumerate(tokens):
        for other in token.split("|")[1:] if "|" in token else []:
            variants.append([*variants[0][:i], other, *variants[0][i + 1 :]])
    return variants


def _takes_value(command, flag: str) -> bool:
    for action in command._actions:
        if flag in action.option_strings:
            return action.nargs != 0
    return False


def parse(command_line: str, inline: bool) -> None:
    """Parse one command line of the docs (see the module); raise UsageError if it is wrong."""
    parser = PARSERS[inline]
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    tokens = shlex.split(command_line)[1:]
    if tokens and tokens[0] in sub and any(t in ("-h", "--help") for t in tokens):
        return
    for words in _variants(tokens):
        command = sub.get(words[0]) if words else None
        kept = []
        for word in words:  # a '...' that follows no option: more options
            if word == "..." and not (kept and kept[-1].startswith("-") and command is not None
                                      and _takes_value(command, kept[-1])):  # fmt: skip
                continue
            kept.append(word)
        if (
            inline
            and command is not None
            and kept[-1].startswith("-")
            and _takes_value(command, kept[-1])
        ):
            kept = kept[:-1]  # the flag named, its value left out
        parser.parse_args(kept)


def _all_commands():
    for page in PAGES:
        for line, command, inline in commands_of((ROOT / page).read_text(encoding="utf-8")):
            if re.match(r"^symladders [\w-]+:", command):
                continue  # the command's output
            yield pytest.param(page, line, command, inline, id=f"{page}:{line}")


DOC_COMMANDS = list(_all_commands())


def test_the_docs_have_commands_in_code_blocks_and_prose():
    kinds = {inline for *_, inline in (p.values for p in DOC_COMMANDS)}
    assert kinds == {True, False} and len(DOC_COMMANDS) > 80


@pytest.mark.parametrize(("page", "line", "command", "inline"), DOC_COMMANDS)
def test_every_command_in_the_docs_parses(page, line, command, inline):
    if command in SHOWN_WRONG:
        with pytest.raises(UsageError):
            parse(command, inline)
        return
    try:
        parse(command, inline)
    except UsageError as exc:
        pytest.fail(f"{page}, line {line}: {command!r}: {exc}")


@pytest.mark.parametrize(
    ("command", "inline"),
    [
        ("symladders analyze study --groups g.csv --compare a b", False),  # a wrong format
        ("symladders mesh images/*.nii.gz --label 1 --frame 0,9", False),  # an unknown flag
        ("symladders mesh images/*.nii.gz --label one", False),  # a wrong value
        ("symladders mesh images/*.nii.gz", False),  # a missing argument
        ("symladders correspond --atlas atlas.txt --meshes M", False),  # not a mesh file
        ("symladders study --jobs 0", True),  # a wrong value, inline
        ("symladders track --cut-plane", True),  # track has no --cut-plane
        ("symladders stduy", True),
    ],
)
def test_a_wrong_command_is_caught(command, inline):
    with pytest.raises(UsageError):
        parse(command, inline)


def test_the_rules_accept_placeholders_synopses_and_shell_lines():
    parse("symladders analyze STUDY_OUTPUT --groups groups.csv --compare A,B --alpha2 ...", False)
    parse(
        "symladders correspond --atlas ATLAS --meshes FOLDER -o OUTPUT [--units auto|mm|cm]", False
    )
    with pytest.raises(UsageError):  # every alternative is parsed
        parse("symladders correspond --atlas a.vtk --meshes M [--units auto|inch]", False)
    parse("symladders study [--meshes DIR | --cohort TABLE] [--seed 1]", False)
    with pytest.raises(UsageError):  # exclusive: each alternative alone
        parse("symladders study --meshes DIR --cohort TABLE", False)
    with pytest.raises(UsageError):
        parse("symladders study [--meshes DIR | --cohort TABLE --bad 1]", False)
    found = commands_of("```sh\nPYTHONPATH=. symladders study \\\n  --full  # all\n"
                        "pip install . && symladders validate | head\n```\n"
                        "Run `symladders track --cut-planes` or `symladders atlas: done`.\n")  # fmt: skip
    assert found == [(2, "symladders study --full", False), (4, "symladders validate", False),
                     (6, "symladders track --cut-planes", True), (6, "symladders atlas: done", True)]  # fmt: skip
