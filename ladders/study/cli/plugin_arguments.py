"""Deformation models on the command line: ``--deformation NAME[,NAME...]`` and ``--plugin``.

``--plugin MODULE_OR_FILE`` imports a module (a name on the Python path, or a ``.py``
file) that registers deformation models
(:func:`ladders.study.deformations.register_deformation`). :func:`preload_plugins`
loads the ``--plugin`` values of a command line before it is parsed, so that
``--deformation`` accepts the names they register wherever the flags stand.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from .cli_types import UsageError

__all__ = [
    "add_plugin_argument",
    "deformation_list",
    "one_deformation",
    "registered_names",
    "preload_plugins",
    "PluginAction",
]


def registered_names() -> tuple[str, ...]:
    """The registered models' names (those known so far if a plugin fails to load: the
    failure is reported when ``--deformation`` is checked)."""
    from ..deformations import deformation_names

    return deformation_names(strict=False)


def deformation_list(text: str) -> str:
    """The value of ``--deformation``, checked: registered names, comma-separated, or
    ``both`` (``lddmm,svf``); returned as given (:func:`~ladders.study.deformations.parse_deformations`
    splits it)."""
    from ..deformations import DeformationModelError, parse_deformations

    try:
        parse_deformations(text)
    except DeformationModelError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def one_deformation(text: str) -> str:
    """The value of a ``--deformation`` that takes one registered model's name."""
    if "," in text or text == "both":
        raise argparse.ArgumentTypeError(f"expected one model's name, got {text!r}")
    return deformation_list(text)


class PluginAction(argparse.Action):
    """Load the plugin as soon as the flag is read (and keep the list in ``dest``)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from ..deformations import DeformationModelError, load_plugin

        try:
            load_plugin(values)
        except DeformationModelError as exc:
            parser.error(f"argument {option_string}: {exc}")
        plugins = list(getattr(namespace, self.dest, None) or [])
        setattr(namespace, self.dest, [*plugins, values])


def add_plugin_argument(p) -> None:
    """Add ``--plugin`` to the parser ``p``."""
    p.add_argument(
        "--plugin",
        action=PluginAction,
        default=None,
        metavar="MODULE_OR_FILE",
        help="import a module or a .py file that registers deformation models "
        "(register_deformation), before --deformation is read; repeatable. The variable "
        "SYMLADDERS_PLUGINS does the same (os.pathsep-separated)",
    )


def preload_plugins(argv: Sequence[str]) -> None:
    """Load every ``--plugin X`` / ``--plugin=X`` of ``argv`` (before it is parsed).

    Raises
    ------
    UsageError
        A plugin that cannot be imported (one line naming it).
    """
    from ..deformations import DeformationModelError, load_plugin

    args = list(argv)
    specs = [v for flag, v in zip(args, args[1:]) if flag == "--plugin"]
    specs += [a.split("=", 1)[1] for a in args if a.startswith("--plugin=")]
    for spec in specs:
        try:
            load_plugin(spec)
        except DeformationModelError as exc:
            raise UsageError(f"symladders: error: argument --plugin: {exc}") from None
