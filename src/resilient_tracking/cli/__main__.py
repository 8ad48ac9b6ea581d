"""``python -m resilient_tracking.cli``: the same as ``rtrack``."""

import sys

from resilient_tracking.cli import main

if __name__ == "__main__":
    sys.exit(main())
