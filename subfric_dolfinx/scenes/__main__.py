"""``python3 -m subfric_dolfinx.scenes SCENE.json --out DIR`` (console script: subfric-scene)."""

import sys

from .command import main

sys.exit(main())
