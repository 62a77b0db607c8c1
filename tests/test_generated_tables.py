"""Every benchmark figure in the README and the docs comes from its generated table, unedited."""

import datetime
import json
import re
import sys

import pytest

from tests.docs_pages import PAGES, ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))
import generated_tables  # noqa: E402

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
    toc = {
        line.strip()
        for tree in re.findall(r"```\{toctree\}\n(.*?)```", index, re.S)
        for line in tree.splitlines()
        if line.strip() and not line.strip().startswith(":")
    }
    docs = ROOT / "docs"
    pages = {p.relative_to(docs).with_suffix("").as_posix() for p in PAGES if docs in p.parents}
    assert pages - {"index"} <= toc, sorted(pages - {"index"} - toc)


@pytest.mark.parametrize("store", sorted((ROOT / "docs" / "generated").glob("*.rows.json")))
def test_per_cpu_tables_list_their_stored_rows(store):
    text = store.with_name(store.name.replace(".rows.json", ".md")).read_text(encoding="utf-8")
    stored = json.loads(store.read_text(encoding="utf-8"))
    assert generated_tables._render_rows(stored["header"], stored["rows"]) in text


def test_publish_rows_replaces_this_cpus_row_and_keeps_the_others(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("intro\n<!-- BEGIN generated/t -->\nold\n<!-- END generated/t -->\nend\n")
    other = {"cpu": "Other CPU", "cores": 64, "simd": "avx512", "date": "2020-01-02",
             "cells": {"time": "1 s"}}  # fmt: skip
    header = ["load", "time"]
    publish = lambda cells: generated_tables.publish_rows(  # noqa: E731
        "t", header, cells, "python bench.py", seed=[other], folder=tmp_path, pages=[page]
    )
    publish({"load": "0.50", "time": "9 s"})
    path = publish({"load": "0.25", "time": "7 s"})  # the seed is used only once
    stored = json.loads((tmp_path / "t.rows.json").read_text())["rows"]
    assert [r["cpu"] for r in stored] == ["Other CPU", generated_tables._cpu_model()]
    assert stored[0] == other and stored[1]["cells"] == {"load": "0.25", "time": "7 s"}
    text = path.read_text()
    assert re.search(r"cores, \w+, measured \d{4}-\d\d-\d\d", text.splitlines()[0])
    today = datetime.date.today().isoformat()
    assert "| CPU | date | load | time |" in text
    assert "| Other CPU, 64 cores, avx512 | 2020-01-02 | – | 1 s |" in text
    here = generated_tables.this_cpu()
    assert (
        f"| {here['cpu']}, {here['cores']} cores, {here['simd']} | {today} | 0.25 | 7 s |" in text
    )
    assert "9 s" not in text
    assert (
        page.read_text()
        == f"intro\n<!-- BEGIN generated/t -->\n{text}<!-- END generated/t -->\nend\n"
    )
    assert not (ROOT / "docs" / "generated" / "t.md").exists()


def test_publishing_main_writes_only_when_asked(tmp_path, capsys, monkeypatch):
    """A benchmark's ``[--publish]`` command line: the table is printed with the machine,
    and written (with the script's command) only with ``--publish``."""
    monkeypatch.setattr(sys, "argv", ["bench_example.py"])
    page = tmp_path / "page.md"
    page.write_text("<!-- BEGIN generated/example -->\nold\n<!-- END generated/example -->\n")
    kw = dict(folder=tmp_path / "generated", pages=[page])
    table = generated_tables.publishing_main("example", "Doc.\nmore", lambda: "| 1 |\n", [], **kw)
    assert table == "| 1 |\n" and "cores" in capsys.readouterr().out
    assert not (tmp_path / "generated").exists() and "old" in page.read_text()
    generated_tables.publishing_main("example", "Doc.", lambda: "| 2 |\n", ["--publish"], **kw)
    written = (tmp_path / "generated" / "example.md").read_text()
    assert "`python benchmarks/bench_example.py --publish`" in written and "| 2 |" in written
    assert written in page.read_text() and "old" not in page.read_text()
