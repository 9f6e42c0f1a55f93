"""``python -m mechrel``: the ``mechrel`` command."""

import sys

from mechrel.cli.main import main

sys.exit(main())
