"""``python3 -m subfric_dolfinx.driver CASE.json [--steps-per-mm N] [--out OUT.json]``."""

import sys

from .cli import main

sys.exit(main())
