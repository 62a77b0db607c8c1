"""The documentation's pages, by purpose, as the benchmarks' table writer knows them.

``GUIDE_PAGES``: the user guide and the library (``README.md`` and ``docs/*.md``;
``tests/test_docs_sizes.py`` tells them apart by ``docs/index.md``); ``EVIDENCE_PAGES``:
the validation and benchmark reports (``docs/evidence/*.md``); ``PAGES``: both, every
page whose generated regions ``benchmarks/generated_tables.py`` keeps up to date.
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from generated_tables import EVIDENCE_PAGES, GUIDE_PAGES, PAGES  # noqa: E402

__all__ = ["ROOT", "GUIDE_PAGES", "EVIDENCE_PAGES", "PAGES"]
