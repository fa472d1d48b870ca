"""``python -m acc``: the ``acc`` command line."""

import sys

from acc.cli.main import main

sys.exit(main())
