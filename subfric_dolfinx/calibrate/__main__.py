"""``python3 -m subfric_dolfinx.calibrate DATA.json --out FIT.json [--plot FIT.png]``."""

import sys

from .cli import main

sys.exit(main())
