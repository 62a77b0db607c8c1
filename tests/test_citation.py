"""CITATION.cff parses and has what CFF 1.2.0 requires, and the paper's facts."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The keys CFF 1.2.0 allows in a reference (schema.json, definitions.reference).
REFERENCE_KEYS = {
    "abbreviation", "abstract", "authors", "collection-doi", "collection-title",
    "collection-type", "commit", "conference", "contact", "copyright", "data-type",
    "database", "database-provider", "date-accessed", "date-downloaded", "date-published",
    "date-released", "department", "doi", "edition", "editors", "editors-series", "end",
    "entry", "filename", "format", "identifiers", "institution", "isbn", "issn", "issue",
    "issue-date", "issue-title", "journal", "keywords", "languages", "license", "license-url",
    "loc-end", "loc-start", "location", "medium", "month", "nihmsid", "notes", "number",
    "number-volumes", "pages", "patent-states", "pmcid", "publisher", "recipients",
    "repository", "repository-artifact", "repository-code", "scope", "section", "senders",
    "start", "status", "term", "thesis-type", "title", "translators", "type", "url",
    "version", "volume", "volume-title", "year", "year-original",
}  # fmt: skip


@pytest.fixture(scope="module")
def cff():
    yaml = pytest.importorskip("yaml")
    return yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))


def test_the_required_fields(cff):
    assert cff["cff-version"] == "1.2.0"
    for key in ("message", "title", "authors"):
        assert cff.get(key), key
    assert cff["type"] == "software"
    # the repository's public address, when the file gives one, is a web address
    if "repository-code" in cff:
        assert re.match(r"^https?://.+", cff["repository-code"])
        assert "REPLACE" not in cff["repository-code"]


def test_title_and_version_are_the_package_s(cff):
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    version = re.search(r'^version = "([^"]+)"', pyproject, re.M).group(1)
    assert str(cff["version"]) == version
    assert cff["title"].startswith("symladders")


def test_the_preferred_citation_is_the_paper(cff):
    paper = cff["preferred-citation"]
    assert set(paper) <= REFERENCE_KEYS, sorted(set(paper) - REFERENCE_KEYS)
    assert paper["type"] == "conference-paper"
    assert paper["title"] == (
        "Symmetric Algorithmic Components for Shape Analysis with Diffeomorphisms"
    )
    names = [(a["given-names"], a["family-names"]) for a in paper["authors"]]
    assert names == [("Nicolas", "Guigui"), ("Shuman", "Jia"), ("Maxime", "Sermesant"),
                     ("Xavier", "Pennec")]  # fmt: skip
    assert paper["year"] == 2019
