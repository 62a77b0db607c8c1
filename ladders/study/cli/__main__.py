"""``python -m ladders.study.cli``: the ``symladders`` command."""

import sys

from .entry import main

sys.exit(main())
