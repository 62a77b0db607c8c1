"""The user guide is read in an hour and leads to its evidence.

The guide (``README.md`` and ``docs/*.md``: what to do and what a result means) keeps
each page under :data:`MAX_PAGE_LINES` lines and all of it under :data:`MAX_GUIDE_LINES`;
the evidence (``docs/evidence/*.md``: the validation and benchmark reports, their
generated tables, causes and history) is as long as it needs, and each of its pages is
linked from the guide. The generated API reference (``docs/api.rst``) is not a page of
either.
"""

import re

import pytest

from tests.docs_pages import EVIDENCE_PAGES, GUIDE_PAGES, ROOT

MAX_PAGE_LINES = 400
MAX_GUIDE_LINES = 3500


def _lines(page) -> int:
    return len(page.read_text(encoding="utf-8").splitlines())


@pytest.mark.parametrize("page", GUIDE_PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_a_guide_page_is_short(page):
    assert _lines(page) <= MAX_PAGE_LINES, (
        f"{page.relative_to(ROOT)}: {_lines(page)} lines; move its measurements and their "
        "causes to docs/evidence/ and link them"
    )


def test_the_guide_is_read_in_an_hour():
    counts = {p.relative_to(ROOT).as_posix(): _lines(p) for p in GUIDE_PAGES}
    assert sum(counts.values()) < MAX_GUIDE_LINES, counts


def test_every_evidence_page_is_linked_from_the_guide():
    links = set()
    for page in GUIDE_PAGES:
        for target in re.findall(r"\]\(([^)#\s]+\.md)", page.read_text(encoding="utf-8")):
            links.add((page.parent / target).resolve())
    unlinked = [p.relative_to(ROOT).as_posix() for p in EVIDENCE_PAGES if p.resolve() not in links]
    assert not unlinked, f"evidence pages no guide page links to: {unlinked}"


def test_the_guide_and_the_evidence_are_found():
    assert ROOT / "README.md" in GUIDE_PAGES and ROOT / "docs" / "index.md" in GUIDE_PAGES
    assert EVIDENCE_PAGES, "no page in docs/evidence/"
    assert not set(GUIDE_PAGES) & set(EVIDENCE_PAGES)
