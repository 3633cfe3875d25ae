"""``python -m splatloop run --planner python:MODULE:CLASS ...``: see ``splatloop.cli``."""

import sys

from .cli import main

sys.exit(main(sys.argv[1:]))
