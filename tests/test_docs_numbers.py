"""No measured number is typed by hand into the README or the docs.

Every measured figure (a time, an error, a p-value, a power, Dice, AUC, FWER or
C-index value, a speed ratio, an outcome percentage) comes from a benchmark's
generated region (``<!-- BEGIN generated/<name> -->`` ... ``<!-- END ... -->``,
copied from ``docs/generated/<name>.md`` by ``benchmarks/generated_tables.py``).

The rule, per page (``README.md``, ``docs/*.md`` and ``docs/evidence/*.md``, not
``docs/generated/``):

* Skipped: generated regions and fenced code blocks (a line starting with three
  backticks opens or closes one); inline code spans (`` `...` ``: commands, options,
  code, i.e. settings) are skipped too, except for the last pattern below.
* Flagged, in what is left: a number followed by a unit (ms, s, sec, seconds, min,
  minutes, h, hours, mm, %, degrees, deg, °, times, x or × as in "5 x faster"); a
  p-value (``p = 0.18``, ``p < 1e-3``, ``p at most 0.01``, ``p of 0.2``); a named score
  followed by a number (AUC, Dice, power, FWER, C-index, SD, with an optional "of",
  "=", ":", "is", "about", "~", "≈" in between); a number in scientific notation
  (``2e-6``, ``1.5e+3``, ``3 x 10^-4``); inside inline code only one with a decimal
  mantissa (``4.5e-16`` is a result, a tolerance is written ``1e-12``). A number and
  its unit may be split by a line break; the hit is reported on the number's line.
* Allowed: a hit whose number lies inside an occurrence, on its own line, of a phrase
  listed for that page in ``tests/docs_numbers_allowed.txt``
  (``<page>: <exact phrase>  # setting|target|definition``). Only settings, targets and
  definitions belong there; a measured figure goes into a generated table instead.
  An entry that allows no hit any more is stale and fails the test.
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path

import pytest

from tests.docs_pages import PAGES, ROOT

ALLOWED_FILE = Path(__file__).with_name("docs_numbers_allowed.txt")
KINDS = ("setting", "target", "definition")

REGION = re.compile(r"<!-- BEGIN generated/(\S+) -->.*?<!-- END generated/\1 -->", re.S)
INLINE_CODE = re.compile(r"(`+)(?!`).*?(?<!`)\1(?!`)", re.S)

_NUM = r"(?<![\w.])(?P<num>[-+−±]?\d+(?:,\d{3})*(?:\.\d+)?(?:[eE][-+−]?\d+)?)"
_UNIT = r"(?:ms|s|sec|seconds?|min|minutes?|h|hours?|mm|%|degrees?|deg|°|times|x|×)"
_SCORE = r"(?:AUC|Dice|power|FWER|C-index|SD)"
#: The patterns of a measured-looking number; each has a group ``num``, the number.
PATTERNS = [
    re.compile(_NUM + r"[ \t]*\n?[ \t]*" + _UNIT + r"(?![\w])"),
    re.compile(r"\bp[ \t]*(?:=|<|>|≤|≥|<=|>=|at most|below|of)[ \t]*" + _NUM),
    re.compile(r"\b" + _SCORE + r"\b[ \t]*(?:of|=|:|is|was|about|~|≈)?[ \t]*" + _NUM + r"(?![\w])"),
    re.compile(r"(?<![\w.])(?P<num>\d+(?:\.\d+)?(?:[eE][-+−]?\d+|\s*[x×]\s*10\^[-−]?\d+))\b"),
]
#: A result in scientific notation, flagged in inline code as well.
DECIMAL_SCIENTIFIC = re.compile(r"(?<![\w.])(?P<num>\d+\.\d+[eE][-+−]?\d+)\b")


def _blank(match: re.Match, fill: str = " ") -> str:
    """The matched text with every character but newlines replaced by ``fill``."""
    return re.sub(r"[^\n]", fill, match.group(0))


def prose(text: str, inline_code: bool = False) -> str:
    """``text`` with generated regions, fenced code blocks and inline code blanked out.

    With ``inline_code`` inline code is kept. Blanking keeps every character's line and
    column, so hits keep their line numbers.
    """
    text = REGION.sub(_blank, text)
    lines, fenced = [], False
    for line in text.split("\n"):
        toggle = line.lstrip().startswith("```")
        lines.append(" " * len(line) if fenced or toggle else line)
        fenced ^= toggle
    text = "\n".join(lines)
    # inline code becomes a mark, not a space, so that "10 `x` mm" does not read "10 mm"
    return text if inline_code else INLINE_CODE.sub(lambda m: _blank(m, "¦"), text)


def scan(text: str) -> list[tuple[int, int, int, str]]:
    """The measured-looking numbers of a page: ``(line, start, end, line text)`` each.

    ``line`` counts from 1; ``start:end`` is the number's column span in the line.
    """
    clean, with_code = prose(text), prose(text, inline_code=True)
    lines = text.split("\n")
    starts = [0]
    for line in lines[:-1]:
        starts.append(starts[-1] + len(line) + 1)
    hits = set()
    searches = [(pattern, clean) for pattern in PATTERNS]
    for pattern, searched in [*searches, (DECIMAL_SCIENTIFIC, with_code)]:
        for match in pattern.finditer(searched):
            pos = match.start("num")
            number = searched.count("\n", 0, pos)
            col = pos - starts[number]
            hits.add((number + 1, col, col + len(match.group("num")), lines[number]))
    return sorted(hits)


def is_allowed(hit: tuple[int, int, int, str], phrases: list[str]) -> str | None:
    """The phrase (if any) that covers the hit's number on its line."""
    _, start, end, line = hit
    for phrase in phrases:
        for found in re.finditer(re.escape(phrase), line):
            if found.start() <= start and end <= found.end():
                return phrase
    return None


def load_allowed(path: Path = ALLOWED_FILE) -> dict[str, list[str]]:
    """The allow-list: page -> phrases; ``#`` lines and blank lines are comments."""
    allowed: dict[str, list[str]] = defaultdict(list)
    for n, raw in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if not raw.strip() or raw.startswith("#"):
            continue
        entry, sep, kind = raw.rpartition("  # ")
        page, colon, phrase = entry.partition(": ")
        assert sep and colon and phrase, f"{path.name}:{n}: not '<page>: <phrase>  # <kind>'"
        assert kind.strip() in KINDS, f"{path.name}:{n}: kind must be one of {KINDS}"
        assert (ROOT / page).is_file(), f"{path.name}:{n}: no page {page}"
        allowed[page].append(phrase)
    return allowed


def _page_hits() -> dict[str, list[tuple[int, int, int, str]]]:
    return {
        page.relative_to(ROOT).as_posix(): scan(page.read_text(encoding="utf-8")) for page in PAGES
    }


@pytest.mark.parametrize("page", [p.relative_to(ROOT).as_posix() for p in PAGES])
def test_no_hand_typed_measured_number(page):
    phrases = load_allowed().get(page, [])
    hits = scan((ROOT / page).read_text(encoding="utf-8"))
    bad = [
        f"{page}:{n}: {line.strip()}"
        for n, *_, line in hits
        if not is_allowed((n, *_, line), phrases)
    ]
    assert not bad, (
        "measured numbers outside a generated region (put them into a benchmark's "
        "generated table, or allow-list a true setting/target/definition in "
        f"tests/{ALLOWED_FILE.name}):\n" + "\n".join(dict.fromkeys(bad))
    )


def test_allow_list_has_no_stale_entry():
    hits = _page_hits()
    stale = [
        f"{page}: {phrase}"
        for page, phrases in load_allowed().items()
        for phrase in phrases
        if not any(is_allowed(hit, [phrase]) for hit in hits.get(page, []))
    ]
    assert not stale, "allow-list entries that allow no number any more:\n" + "\n".join(stale)


def test_scanner_flags_only_measured_numbers_in_prose():
    page = "\n".join(
        [
            "The registration takes 1.30 ms per evaluation.",  # 1: flagged
            "<!-- BEGIN generated/t -->",
            "| 0.14 s | p = 0.02 |",  # 3: inside a generated region
            "<!-- END generated/t -->",
            "```",
            "took 3.5 s, AUC 0.9",  # 6: inside a code block
            "```",
            "Run `--time 5 min` on 1.5 mm voxels.",  # 8: inline code; 1.5 mm is a setting
            "It is 39",  # 9: flagged (unit on the next line)
            "times faster, p < 1e-3 and Dice 0.91; the error is 2e-6.",  # 10: four hits
            "Twelve subjects, 3 groups, version 2.0, `tol = 1e-12`, `4.5e-16`.",  # 11: one hit
        ]
    )
    hits = scan(page)
    assert [(n, line[s:e]) for n, s, e, line in hits] == [
        (1, "1.30"),
        (8, "1.5"),
        (9, "39"),
        (10, "1e-3"),
        (10, "0.91"),
        (10, "2e-6"),
        (11, "4.5e-16"),
    ]
    allowed = [h for h in hits if is_allowed(h, ["1.5 mm voxels"])]
    assert [n for n, *_ in allowed] == [8]
    assert not is_allowed(hits[0], ["1.5 mm voxels", "per evaluation"])
