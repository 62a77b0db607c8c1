"""The user guide is read in an hour and leads to its evidence.

The pages come in three parts, as ``docs/index.md`` lists them: the user guide (the
README and the pages of the toctree "The user guide": what to do and what a result
means), the library (the toctree "The library": the spaces, the ladders, the
registrations and the statistics, for building on them) and the evidence (``docs/evidence/*.md``, the
toctree "The evidence": the validation and benchmark reports, their generated tables,
causes and history). A guide or library page stays under :data:`MAX_PAGE_LINES`
lines and the user guide under :data:`MAX_GUIDE_LINES` in all; the evidence is as long
as it needs, and each of its pages is linked from the guide or the library. The
generated API reference (``docs/api.rst``) is not counted.
"""

import re

import pytest

from tests.docs_pages import EVIDENCE_PAGES, GUIDE_PAGES, ROOT

MAX_PAGE_LINES = 400
MAX_GUIDE_LINES = 3500
DOCS = ROOT / "docs"


def toctree(caption: str) -> list:
    """The Markdown pages of the toctree of docs/index.md with this caption."""
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    for tree in re.findall(r"```\{toctree\}\n(.*?)```", index, re.S):
        lines = [line.strip() for line in tree.splitlines() if line.strip()]
        if f":caption: {caption}" in lines:
            pages = [DOCS / f"{line}.md" for line in lines if not line.startswith(":")]
            return [page for page in pages if page.exists()]
    raise AssertionError(f"docs/index.md has no toctree captioned {caption!r}")


USER_GUIDE = [ROOT / "README.md", DOCS / "index.md", *toctree("The user guide")]
LIBRARY = toctree("The library")


def _lines(page) -> int:
    return len(page.read_text(encoding="utf-8").splitlines())


def _name(page) -> str:
    return page.relative_to(ROOT).as_posix()


@pytest.mark.parametrize("page", USER_GUIDE + LIBRARY, ids=_name)
def test_a_guide_page_is_short(page):
    assert _lines(page) <= MAX_PAGE_LINES, (
        f"{_name(page)}: {_lines(page)} lines; move its measurements and their causes to "
        "docs/evidence/ and link them"
    )


def test_the_user_guide_is_read_in_an_hour():
    counts = {_name(p): _lines(p) for p in USER_GUIDE}
    assert sum(counts.values()) < MAX_GUIDE_LINES, counts


def test_every_page_is_in_one_part():
    parts = [set(USER_GUIDE), set(LIBRARY), set(EVIDENCE_PAGES)]
    assert set(GUIDE_PAGES) | set(EVIDENCE_PAGES) == set().union(*parts)
    assert sum(len(p) for p in parts) == len(set().union(*parts)), "a page in two parts"
    assert set(toctree("The evidence")) == set(EVIDENCE_PAGES)


def test_every_evidence_page_is_linked_from_the_guide_or_the_library():
    links = set()
    for page in USER_GUIDE + LIBRARY:
        for target in re.findall(r"\]\(([^)#\s]+\.md)", page.read_text(encoding="utf-8")):
            links.add((page.parent / target).resolve())
    unlinked = [_name(p) for p in EVIDENCE_PAGES if p.resolve() not in links]
    assert not unlinked, f"evidence pages no guide or library page links to: {unlinked}"
