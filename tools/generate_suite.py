"""Write the generalization benchmark's fixed suite (docs/generalization.md) to package data.

    python tools/generate_suite.py            # regenerate src/.../experiments/suite-2024.json
    python tools/generate_suite.py --check    # exit 1 if the stored suite differs

The generator runs the vanilla team once per scenario to check that it meets every zone, so the
suite depends on the planner as well as on the seed. The stored file pins it: the benchmark
runs the same scenarios after any change, and ``tests/test_generalization.py`` says when the
generator's output has drifted from it.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys

from resilient_tracking.experiments.catalog import SUITE_SIZE
from resilient_tracking.experiments.generator import SUITE_PATH, SUITE_SEED, suite


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO)
    data = [s.model_dump(mode="json") for s in suite(SUITE_SEED, SUITE_SIZE)]
    text = json.dumps({"seed": SUITE_SEED, "scenarios": data}, indent=1) + "\n"
    if args.check:
        same = SUITE_PATH.read_text(encoding="utf-8") == text
        print("stored suite is current" if same else f"{SUITE_PATH} differs from the generator")
        return 0 if same else 1
    SUITE_PATH.write_text(text, encoding="utf-8")
    print(f"wrote {len(data)} scenarios to {SUITE_PATH}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
