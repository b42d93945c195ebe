"""``python -m cocomopl``: the same as the ``cocomopl`` command."""

import sys

from cocomopl.cli import main

sys.exit(main())
