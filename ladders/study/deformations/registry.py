"""The registry of deformation models, by name: the built-in ones and any a user adds.

A model becomes known to the study, to ``symladders study --deformation NAME`` and
to every worker process of a study in one of three ways:

* :func:`register_deformation` in Python (a script, a notebook, a module that
  registers its models when imported: the built-in ``lddmm`` and ``svf`` are
  registered so, by :mod:`ladders.study.deformations.lddmm` and ``.svf``);
* a plugin named in the environment variable :data:`PLUGINS_VARIABLE`
  (``SYMLADDERS_PLUGINS``): module names or paths of ``.py`` files, separated by
  ``os.pathsep``, imported when a name is first looked up; or ``--plugin
  MODULE_OR_FILE`` of ``symladders study``, ``cycle-study`` and ``validate``, which
  loads it the same way;
* an installed package's entry point in the group :data:`ENTRY_POINT_GROUP`
  (``symladders.deformations``): ``pdm = "my_package.models:PointDistributionModel"``
  (a class or an instance), loaded when a name is first looked up.

A model loaded from a plugin is pickled as its plugin and name, so the processes of
a parallel study load the plugin again rather than needing it on their path.
"""

from __future__ import annotations

import copyreg
import hashlib
import importlib
import importlib.util
import os
import sys
from pathlib import Path

from .model import NAME_PATTERN, DeformationModel

__all__ = [
    "ENTRY_POINT_GROUP",
    "PLUGINS_VARIABLE",
    "BOTH",
    "DeformationModelError",
    "register_deformation",
    "unregister_deformation",
    "deformation_model",
    "deformation_names",
    "parse_deformations",
    "load_plugin",
    "plugin_source",
    "restore_model",
    "transport_label",
]

ENTRY_POINT_GROUP = "symladders.deformations"
PLUGINS_VARIABLE = "SYMLADDERS_PLUGINS"
#: ``--deformation both``: the two built-in models, kept from before models were registered.
BOTH = ("lddmm", "svf")

_MODELS: dict[str, DeformationModel] = {}
_SOURCES: dict[str, str] = {}  # name -> the plugin that registered it
_LOADED: dict[str, object] = {}  # plugin -> its module
_loading: list[str] = []  # the plugin being imported (registrations are credited to it)
_external_loaded = False


class DeformationModelError(ValueError):
    """A deformation model that is unknown or breaks the interface (the message names it)."""


def register_deformation(model, *, replace: bool = False) -> DeformationModel:
    """Register ``model`` (an instance, or a class built without arguments) under its name.

    Parameters
    ----------
    model : DeformationModel or its subclass
    replace : bool, default False
        Replace a model of another class registered under the same name (registering
        the same class again replaces it silently, also when its file is imported a
        second time: a script run as ``__main__`` and loaded as a plugin).

    Returns
    -------
    DeformationModel
        The registered instance.

    Raises
    ------
    DeformationModelError
        Not a :class:`DeformationModel`, a name that does not match
        :data:`~.model.NAME_PATTERN` (or is ``"both"``), or a name taken.
    """
    if isinstance(model, type) and issubclass(model, DeformationModel):
        model = model()
    if not isinstance(model, DeformationModel):
        raise DeformationModelError(
            f"register_deformation: expected a DeformationModel, got {type(model).__name__}"
        )
    name = model.name
    if not isinstance(name, str) or not NAME_PATTERN.match(name) or name == "both":
        raise DeformationModelError(
            f"{type(model).__name__}: name: expected lower-case letters, digits, '_' or '-' "
            f"(starting with a letter, not 'both'), got {name!r}"
        )
    old = _MODELS.get(name)
    if old is not None and not _same_class(type(old), type(model)) and not replace:
        raise DeformationModelError(
            f"{type(model).__name__}: name {name!r} is taken by {type(old).__name__} "
            "(register_deformation(..., replace=True) replaces it)"
        )
    _MODELS[name] = model
    if _loading:
        _SOURCES[name] = _loading[-1]
        copyreg.pickle(type(model), _reduce)
    else:
        _SOURCES.pop(name, None)
    return model


def _same_class(a: type, b: type) -> bool:
    """The same class, or the same class of the same file imported twice (a script run as
    ``__main__`` and loaded again as a plugin)."""
    if a is b:
        return True

    def where(cls):
        codes = [v.__code__ for v in vars(cls).values() if hasattr(v, "__code__")]
        path = codes[0].co_filename if codes else None  # found without sys.modules
        return cls.__qualname__, str(Path(path).resolve()) if path else None

    return where(a)[1] is not None and where(a) == where(b)


def unregister_deformation(name: str) -> None:
    """Forget the model registered as ``name`` (nothing happens if there is none), and the
    plugin that registered it, so that loading the plugin again registers it again."""
    _MODELS.pop(name, None)
    source = _SOURCES.pop(name, None)
    if source is not None and source not in _SOURCES.values():
        _LOADED.pop(source, None)


def load_plugin(spec: str):
    """Import a plugin: a module name, or the path of a ``.py`` file; return the module.

    The models it registers are credited to it (:func:`plugin_source`). Loading the
    same plugin twice imports it once.

    Raises
    ------
    DeformationModelError
        The module cannot be found, or importing it raised (the message names the
        plugin and the error).
    """
    spec = str(spec).strip()
    is_file = spec.endswith(".py") or os.sep in spec or "/" in spec
    if is_file:  # one name for the file wherever it is named from (and in worker processes)
        spec = str(Path(spec).expanduser().resolve())
    if spec in _LOADED:
        return _LOADED[spec]
    _loading.append(spec)
    try:
        if is_file:
            path = Path(spec)
            if not path.is_file():
                raise DeformationModelError(f"plugin {spec}: no such file")
            digest = hashlib.sha1(spec.encode()).hexdigest()[:10]
            name = f"symladders_plugin_{path.stem}_{digest}"
            module_spec = importlib.util.spec_from_file_location(name, path)
            module = importlib.util.module_from_spec(module_spec)
            sys.modules[name] = module
            try:
                module_spec.loader.exec_module(module)
            except BaseException:
                sys.modules.pop(name, None)
                raise
        else:
            module = importlib.import_module(spec)
    except DeformationModelError:
        raise
    except Exception as exc:
        raise DeformationModelError(
            f"plugin {spec}: importing it failed ({type(exc).__name__}: {exc})"
        ) from exc
    finally:
        _loading.pop()
    _LOADED[spec] = module
    return module


def _environment_plugins() -> list[str]:
    text = os.environ.get(PLUGINS_VARIABLE, "")
    return [p for p in (s.strip() for s in text.split(os.pathsep)) if p]


def _entry_points() -> list:
    from importlib.metadata import entry_points

    return list(entry_points(group=ENTRY_POINT_GROUP))


def _load_external() -> None:
    """The plugins of :data:`PLUGINS_VARIABLE` (every call: the variable may have changed)
    and, once, the installed entry points."""
    global _external_loaded
    for spec in _environment_plugins():
        load_plugin(spec)
    if _external_loaded:
        return
    _external_loaded = True
    for point in _entry_points():
        if point.name in _MODELS:
            continue
        try:
            loaded = point.load()
        except Exception as exc:
            raise DeformationModelError(
                f"entry point {point.name} = {point.value} ({ENTRY_POINT_GROUP}): loading it "
                f"failed ({type(exc).__name__}: {exc})"
            ) from exc
        model = register_deformation(loaded)
        if model.name != point.name:
            raise DeformationModelError(
                f"entry point {point.name} = {point.value} ({ENTRY_POINT_GROUP}): the model "
                f"is named {model.name!r}, not {point.name!r}"
            )


def deformation_names(strict: bool = True) -> tuple[str, ...]:
    """The registered models' names, sorted (plugins and entry points loaded first).

    With ``strict=False`` a plugin or entry point that fails to load is left out
    instead of raising (:class:`DeformationModelError`): the names known so far.
    """
    try:
        _load_external()
    except DeformationModelError:
        if strict:
            raise
    return tuple(sorted(_MODELS))


def deformation_model(name) -> DeformationModel:
    """The model registered as ``name`` (a :class:`DeformationModel` is returned as is).

    Raises
    ------
    DeformationModelError
        No model of that name: the message lists the registered ones and how to add one.
    """
    if isinstance(name, DeformationModel):
        return name
    if name not in _MODELS:
        _load_external()
    if name not in _MODELS:
        raise DeformationModelError(
            f"deformation: expected one of {', '.join(sorted(_MODELS))}, got {name!r} (a model "
            f"of your own: register_deformation, {PLUGINS_VARIABLE}=your_module or "
            f"--plugin, or an entry point in {ENTRY_POINT_GROUP})"
        )
    return _MODELS[name]


def parse_deformations(text: str) -> tuple[str, ...]:
    """The names of ``--deformation``: one name, a comma-separated list, or ``both``.

    ``both`` is ``lddmm,svf`` (:data:`BOTH`). Every name must be registered.

    Raises
    ------
    DeformationModelError
        An unknown name (listing the registered ones), a repeated one, or none.
    """
    names = [n.strip() for n in str(text).split(",") if n.strip()]
    names = [m for n in names for m in (BOTH if n == "both" else (n,))]
    if not names:
        raise DeformationModelError(f"deformation: expected a model name, got {text!r}")
    if len(set(names)) != len(names):
        raise DeformationModelError(f"deformation: a model named twice in {text!r}")
    for name in names:
        deformation_model(name)
    return tuple(names)


def plugin_source(model: DeformationModel) -> str | None:
    """The plugin that registered ``model`` (that very instance), or None."""
    name = getattr(model, "name", None)
    if _MODELS.get(name) is model:
        return _SOURCES.get(name)
    return None


def _reduce(model):
    """Pickle a model from a plugin as its name and plugin (any other one as usual)."""
    source = plugin_source(model)
    if source is not None:
        return restore_model, (model.name, source)
    return object.__reduce_ex__(model, 2)


def restore_model(name: str, source: str) -> DeformationModel:
    """The model ``name`` after loading its plugin ``source`` (how a model is unpickled)."""
    if name not in _MODELS:
        load_plugin(source)
    return deformation_model(name)


def transport_label(method: str) -> str | None:
    """What a registered model calls its own transport ``method``, or None."""
    for model in _MODELS.values():
        if model.transport_method == method:
            return model.transport_label
    return None
