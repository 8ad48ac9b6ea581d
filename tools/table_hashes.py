"""Fingerprints of the reproducible run tables: ``python -m resilient_tracking.sim.fingerprints``
with this repository's golden file (``--write`` re-records it; ``--help`` for the rest)."""

from __future__ import annotations

import sys
from pathlib import Path

from resilient_tracking.sim.fingerprints import GOLDEN, main

if __name__ == "__main__":
    main([*sys.argv[1:], "--golden", str(Path(__file__).resolve().parents[1] / GOLDEN)])
