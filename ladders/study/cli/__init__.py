"""The ``symladders`` command line (``symladders = "ladders.study.cli:main"``).

- :mod:`.entry`: the parser and :func:`main`, with its exit statuses;
- :mod:`.study_cli`: ``symladders study``, with its flags in :mod:`.study_arguments`;
- :mod:`.correspond_cli`: ``symladders correspond``; :mod:`.atlas_cli`: ``symladders atlas``;
  their shared flags (units, the data term) in :mod:`.preparation_arguments`;
- :mod:`.validate_cli`: ``symladders validate``;
- :mod:`.cli_types`: argument types and one-line error reporting.
"""

from .entry import build_parser, main

__all__ = ["main", "build_parser"]
