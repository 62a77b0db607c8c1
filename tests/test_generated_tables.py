"""Every benchmark figure in the README and the docs comes from its generated table, unedited."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
REGION = re.compile(r"<!-- BEGIN generated/(\S+) -->\n(.*?)<!-- END generated/\1 -->", re.S)


def _regions():
    for page in PAGES:
        for match in REGION.finditer(page.read_text(encoding="utf-8")):
            yield page.relative_to(ROOT).as_posix(), match.group(1), match.group(2)


@pytest.mark.parametrize("page, name, text", list(_regions()))
def test_marked_region_equals_its_generated_table(page, name, text):
    generated = ROOT / "docs" / "generated" / f"{name}.md"
    assert generated.is_file(), f"{page}: no docs/generated/{name}.md (run its benchmark)"
    assert text == generated.read_text(encoding="utf-8"), (
        f"{page}: the region generated/{name} was edited by hand or is stale; "
        "run the benchmark named in docs/generated/{name}.md"
    )


def test_generated_tables_name_the_machine():
    for path in (ROOT / "docs" / "generated").glob("*.md"):
        first = path.read_text(encoding="utf-8").splitlines()[0]
        assert re.search(r"cores, \w+, measured \d{4}-\d\d-\d\d", first), path.name


def test_the_table_of_contents_lists_every_page():
    index = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    toc = re.search(r"```\{toctree\}\n(.*?)```", index, re.S).group(1).split()
    pages = {p.stem for p in (ROOT / "docs").glob("*.md")} - {"index"}
    assert pages <= set(toc), sorted(pages - set(toc))
