"""``python -m vfxstereo``: the ``vfxstereo`` command, for environments (farm workers) without the script."""

import sys

from vfxstereo.cli import main

sys.exit(main())
