"""The files docs/tutorial_own_data.md says ``symladders run`` writes ("What each step wrote").

The route's tests check them against what their runs wrote: ``test_route.py`` the
ED-ES steps, ``test_route_cycle.py`` the whole cycle's and the wall's.
"""

import re
from pathlib import Path

TUTORIAL = Path(__file__).resolve().parents[1] / "docs" / "tutorial_own_data.md"
#: The folders of the whole cycle and the wall (made when subjects have series, and a
#: myocardium label for the wall).
CYCLE_FOLDERS = ("cycle_study/", "cycle_analysis/", "wall/", "wall_analysis/")


def tree_of_the_tutorial(text: str | None = None) -> list[str]:
    """The paths the tutorial's tree names, relative to the results folder, as glob
    patterns (``<subject>``, ``<step>``, ``<kk>``: any name)."""
    text = TUTORIAL.read_text(encoding="utf-8") if text is None else text
    block = re.search(r"## 4\. What each step wrote\n\n```\n(.*?)```", text, re.S).group(1)
    paths, folder = [], ""
    for line in block.splitlines()[1:]:
        entry, _, description = line.strip().partition("  ")
        if line.startswith("    ") and not line.startswith("     "):
            folder = entry if entry.endswith("/") else ""
            paths.append(entry)
        else:
            description = line.strip()
        names = re.findall(r"(?:[\w<>*-]+/)*[\w<>*.-]+\.(?:md|csv|vtk|vtu|json|npz|png|log)\b"
                           r"|[\w<>-]+/(?=[,:\s]|$)", description)  # fmt: skip
        paths += [folder + name for name in names if folder]
    return [re.sub(r"<\w+>", "*", path) for path in paths]


def missing(results: Path, paths: list[str]) -> list[str]:
    """The paths of ``paths`` (glob patterns) that match nothing under ``results``."""
    return [path for path in paths if not list(results.glob(path.rstrip("/")))]
