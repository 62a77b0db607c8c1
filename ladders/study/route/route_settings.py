"""The settings file of ``symladders run``: a small TOML file whose every key has the
recommended default.

Only ``subjects`` is required::

    subjects = "subjects.csv"

    [images]
    label = 1        # the left ventricle's blood pool
    rv_label = 3     # the right ventricle's: landmarks, AHA segments

    [model]
    formula = "group + age + sex"

Every key, its type, default and meaning is in :data:`SETTINGS`; ``symladders run
--template`` prints them as a commented file. An unknown section or key, or a value of
the wrong type, is refused in one line naming the file and the key (with the nearest
known key). Paths are relative to the settings file's folder.
"""

from __future__ import annotations

import difflib
import sys
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import CohortError
from ..recommendations import RECOMMENDED_ALPHA2

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["RouteSettingsError", "RouteSettings", "SETTINGS", "read_route_settings",
           "settings_template"]  # fmt: skip


class RouteSettingsError(CohortError):
    """A settings file that cannot be used; the message names the file and the key."""


@dataclass(frozen=True)
class _Key:
    kind: str  # "path", "int", "float", "bool", "str", "list", "choice:a|b"
    default: object
    help: str
    optional: bool = False  # None allowed (the key absent means the default)


#: Every section and key: type, default and meaning. The top-level keys are under "".
SETTINGS: dict[str, dict[str, _Key]] = {
    "": {
        "subjects": _Key("path", None, "the subjects table (CSV): one row per subject"),
        "output": _Key(
            "path",
            None,
            "the results folder (default: <settings name>_results beside the settings file)",
            optional=True,
        ),  # fmt: skip
    },
    "images": {
        "label": _Key("int", 1, "the left ventricle's blood pool label"),
        "rv_label": _Key(
            "int",
            None,
            "the right ventricle's label: each subject's apex, "
            "base-plane centre and septal point, which fix the turn "
            "about the long axis and place the AHA segments",
            optional=True,
        ),  # fmt: skip
        "myocardium_label": _Key(
            "int",
            None,
            "the left ventricle's myocardium label: the tracked subjects' wall "
            "thickness, thickening and strain",
            optional=True,
        ),  # fmt: skip
        "vertices": _Key("int", 1000, "vertices of every mesh (the atlas has as many)"),
        "valve_planes": _Key(
            "path",
            None,
            "a table of valve planes (subject, frame, x, y, z, "
            "nx, ny, nz; frame a number, 'ed', 'es' or empty for "
            "all): every mesh cut at its plane",
            optional=True,
        ),  # fmt: skip
    },
    "atlas": {
        "subset": _Key(
            "int",
            50,
            "the atlas is estimated from at most this many subjects "
            "(every subject is then corresponded to it)",
        ),  # fmt: skip
        "max_iter": _Key("int", 10, "iterations of the atlas's estimation"),
    },
    "transport": {
        "alpha2": _Key(
            "float",
            RECOMMENDED_ALPHA2,
            "the regularisation alpha^2 of the registrations (eq. 3); large for group statistics",
        ),  # fmt: skip
        "deformation": _Key(
            "str",
            "lddmm",
            "the deformation model: a registered name (symladders study --deformation)",
        ),  # fmt: skip
        "plugins": _Key(
            "plugins",
            [],
            "modules or .py files that register deformation models of your own "
            "(symladders study --plugin)",
        ),  # fmt: skip
    },
    "tracking": {
        "track": _Key(
            "bool",
            True,
            "follow the subjects with a series of three frames or more "
            "through the cycle, and analyse the cycle",
        ),  # fmt: skip
    },
    "model": {
        "formula": _Key(
            "str",
            None,
            "the linear model on the table's columns (default: every "
            "covariate column, group first)",
            optional=True,
        ),  # fmt: skip
        "contrasts": _Key(
            "list",
            None,
            "the contrasts tested (default: each group against the "
            "reference, or the F test over three groups or more; "
            "without groups, every covariate)",
            optional=True,
        ),  # fmt: skip
        "reference": _Key(
            "str", None, "the reference group (default: the first in the table)", optional=True
        ),  # fmt: skip
        "ignore": _Key("list", [], "columns of the subjects table left out of the model"),
        "blocks": _Key(
            "str", None, "a column of exchangeability blocks (e.g. site)", optional=True
        ),  # fmt: skip
        "outcome": _Key(
            "list",
            None,
            "two columns: follow-up time and event (1) or censored "
            "(0): survival predicted from the motion",
            optional=True,
        ),  # fmt: skip
        "tfce": _Key("bool", True, "threshold-free cluster enhancement on the atlas's mesh"),
        "permutations": _Key("int", 10000, "permutations per test"),
        "alpha": _Key("float", 0.05, "family-wise error level"),
        "fwhm": _Key(
            "float", None, "smooth every subject's maps on the atlas first (mm)", optional=True
        ),  # fmt: skip
        "seed": _Key("int", 0, "seed of the permutations"),
        "truth": _Key(
            "path",
            None,
            "planted_region.json of a synthetic cohort: the report scores the maps against it",
            optional=True,
        ),  # fmt: skip
    },
    "execution": {
        "jobs": _Key("int", -1, "parallel workers (-1: all cores)"),
        "backend": _Key("choice:loky|dask", "loky", "local processes (loky) or a Dask cluster"),
        "scheduler": _Key(
            "str",
            None,
            "address of a running Dask scheduler (with backend = 'dask'; default: a local cluster)",
            optional=True,
        ),  # fmt: skip
    },
}


@dataclass(frozen=True)
class RouteSettings:
    """A read and checked settings file: ``values[section][key]``, defaults filled in.

    Attributes
    ----------
    path : Path
        The settings file (absolute).
    values : dict
        Every section of :data:`SETTINGS` with every key.
    given : dict
        The keys the file set, ``{section: {key: value}}``.
    """

    path: Path
    values: dict
    given: dict = field(default_factory=dict)

    def __getitem__(self, section: str) -> dict:
        return self.values[section]

    @property
    def subjects(self) -> Path:
        return self.values[""]["subjects"]

    @property
    def output(self) -> Path:
        return self.values[""]["output"]


def _fail(path: Path, key: str, message: str):
    raise RouteSettingsError(f"settings {path}, {key}: {message}")


def _nearest(name: str, known) -> str:
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else f" (known: {', '.join(known)})"


def _value(path: Path, name: str, spec: _Key, value):
    kind = spec.kind
    if kind == "path":
        if not isinstance(value, str) or not value.strip():
            _fail(path, name, f"expected a path as a string, got {value!r}")
        p = Path(value).expanduser()
        return (p if p.is_absolute() else path.parent / p).resolve()
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            _fail(path, name, f"expected a whole number, got {value!r}")
        return value
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            _fail(path, name, f"expected a number, got {value!r}")
        return float(value)
    if kind == "bool":
        if not isinstance(value, bool):
            _fail(path, name, f"expected true or false, got {value!r}")
        return value
    if kind == "str":
        if not isinstance(value, str) or not value.strip():
            _fail(path, name, f"expected a non-empty string, got {value!r}")
        return value.strip()
    if kind == "plugins":  # module names, or .py files relative to the settings file
        names = _value(path, name, _Key("list", [], ""), value)
        return [str((path.parent / n).resolve()) if n.endswith(".py") else n for n in names]
    if kind == "list":
        if isinstance(value, str):
            value = [value]
        if not isinstance(value, list) or not all(isinstance(v, str) and v.strip() for v in value):
            _fail(path, name, f"expected a list of strings, got {value!r}")
        return [v.strip() for v in value]
    choices = kind.split(":", 1)[1].split("|")
    if value not in choices:
        _fail(path, name, f"expected one of {', '.join(choices)}, got {value!r}")
    return value


def _check_ranges(path: Path, v: dict) -> None:
    positive = [("images", "label", 0), ("images", "vertices", 100), ("atlas", "subset", 3),
                ("atlas", "max_iter", 0), ("model", "permutations", 1), ("model", "seed", 0)]  # fmt: skip
    for section, key, low in positive:
        if v[section][key] < low:
            _fail(path, f"{section}.{key}", f"expected at least {low}, got {v[section][key]}")
    labels = {"images.label": v["images"]["label"]}
    for key in ("rv_label", "myocardium_label"):
        value = v["images"][key]
        if value is not None and (value == 0 or value in labels.values()):
            _fail(path, f"images.{key}", f"{value}: must differ from 0 and from "
                                         f"{', '.join(labels)}")  # fmt: skip
        labels[f"images.{key}"] = value
    if not v["transport"]["alpha2"] > 0:
        _fail(
            path, "transport.alpha2", f"expected a positive number, got {v['transport']['alpha2']}"
        )
    if not 0 < v["model"]["alpha"] < 1:
        _fail(path, "model.alpha", f"expected a level in (0, 1), got {v['model']['alpha']}")
    jobs = v["execution"]["jobs"]
    if jobs != -1 and jobs < 1:
        _fail(path, "execution.jobs", f"expected -1 (all cores) or a positive number, got {jobs}")
    outcome = v["model"]["outcome"]
    if outcome is not None and len(outcome) != 2:
        _fail(path, "model.outcome", f"expected two columns [time, event], got {outcome}")
    fwhm = v["model"]["fwhm"]
    if fwhm is not None and not fwhm > 0:
        _fail(path, "model.fwhm", f"expected a positive width in mm, got {fwhm}")
    if v["execution"]["scheduler"] is not None and v["execution"]["backend"] != "dask":
        _fail(path, "execution.scheduler", "a scheduler goes with backend = 'dask'")


def read_route_settings(path) -> RouteSettings:
    """Read and check a settings file (see the module).

    Raises
    ------
    RouteSettingsError
        One line naming the file and the key.
    """
    path = Path(path).expanduser().resolve()
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise RouteSettingsError(f"settings {path}: cannot be read ({exc.strerror})") from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise RouteSettingsError(f"settings {path}: not a TOML file ({exc})") from None
    values = {s: {k: spec.default for k, spec in keys.items()} for s, keys in SETTINGS.items()}
    given: dict = {}
    for name, value in data.items():
        if isinstance(value, dict):
            if name not in SETTINGS or not name:
                _fail(path, f"[{name}]", "unknown section" + _nearest(name, list(SETTINGS)[1:]))
            items = [(name, k, v) for k, v in value.items()]
        else:
            items = [("", name, value)]
        for section, key, v in items:
            label = f"{section}.{key}" if section else key
            if key not in SETTINGS[section]:
                known = SETTINGS[section]
                hint = _nearest(key, known)
                if not section:
                    hint = f" (a key of a section? sections: {', '.join(list(SETTINGS)[1:])})"
                _fail(path, label, "unknown key" + hint)
            values[section][key] = _value(path, label, SETTINGS[section][key], v)
            given.setdefault(section, {})[key] = values[section][key]
    if values[""]["subjects"] is None:
        _fail(path, "subjects", 'missing: name the subjects table, e.g. subjects = "subjects.csv"')
    if values[""]["output"] is None:
        values[""]["output"] = path.parent / f"{path.stem}_results"
    _check_ranges(path, values)
    return RouteSettings(path, values, given)


def settings_template(subjects: str = "subjects.csv") -> str:
    """A settings file with every key, commented out at its default but ``subjects``."""
    lines = ["# symladders run: every key but 'subjects' has the recommended default.", ""]
    for section, keys in SETTINGS.items():
        if section:
            lines += ["", f"[{section}]"]
        for key, spec in keys.items():
            lines.append(f"# {spec.help}")
            if key == "subjects":
                lines.append(f'subjects = "{subjects}"')
                continue
            if spec.default is None:
                lines.append(f"# {key} =")
            else:
                lines.append(f"# {key} = {_toml(spec.default)}")
    return "\n".join(lines) + "\n"


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)
