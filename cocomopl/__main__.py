"""``python -m cocomopl``: the same as the ``cocomopl`` command."""

import sys

try:
    from cocomopl.cli import main
except KeyboardInterrupt:  # Ctrl-C before the command started: as main says it once started
    print("cocomopl: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
