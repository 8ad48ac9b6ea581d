"""Write a benchmark's fixed suite (docs/generalization.md, docs/beyond.md) to package data.

    python tools/generate_suite.py            # regenerate src/.../experiments/suite-2024.json
    python tools/generate_suite.py --check    # exit 1 if the stored suite differs
    python tools/generate_suite.py --beyond   # the beyond benchmark's suite-beyond-2024.json
    python tools/generate_suite.py --beyond --check
    python tools/generate_suite.py --beyond --count   # the stored beyond suite's features
    python tools/generate_suite.py --adversarial      # the adversarial benchmark's suite
    python tools/generate_suite.py --adversarial --check

The generator runs the vanilla team once per scenario to check that it meets every zone, so a
suite depends on the planner as well as on the seed. The stored file pins it: the benchmark
runs the same scenarios after any change, and ``tests/test_generalization.py``,
``tests/test_beyond.py`` and ``tests/test_reproduce.py`` say when the generator's output has
drifted from it.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys

from resilient_tracking.experiments.beyond_features import feature_counts
from resilient_tracking.experiments.catalog import ADVERSARIAL_SUITE_SIZE, SUITE_SIZE
from resilient_tracking.experiments.generator import (
    ADVERSARIAL_SUITE_PATH,
    BEYOND_SUITE_PATH,
    SUITE_PATH,
    SUITE_SEED,
    stored_beyond_suite,
    suite,
)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    parser.add_argument(
        "--beyond", action="store_true", help="the beyond benchmark's suite (zone features)"
    )
    parser.add_argument(
        "--adversarial", action="store_true", help="the adversarial benchmark's suite"
    )
    parser.add_argument(
        "--count", action="store_true", help="print the stored beyond suite's zone features"
    )
    args = parser.parse_args()
    if args.count:
        for feature, n in sorted(feature_counts(stored_beyond_suite()).items()):
            print(f"{feature}: {n}")
        return 0
    logging.basicConfig(level=logging.INFO)
    if args.adversarial:
        path = ADVERSARIAL_SUITE_PATH
        drawn = suite(SUITE_SEED, ADVERSARIAL_SUITE_SIZE, adversarial=True)
    else:
        path = BEYOND_SUITE_PATH if args.beyond else SUITE_PATH
        drawn = suite(SUITE_SEED, SUITE_SIZE, beyond=args.beyond)
    data = [s.model_dump(mode="json") for s in drawn]
    kind = {"beyond": True} if args.beyond else {"adversarial": True} if args.adversarial else {}
    head = {"seed": SUITE_SEED, **kind}
    text = json.dumps({**head, "scenarios": data}, indent=1) + "\n"
    if args.check:
        same = path.read_text(encoding="utf-8") == text
        print("stored suite is current" if same else f"{path} differs from the generator")
        return 0 if same else 1
    path.write_text(text, encoding="utf-8")
    print(f"wrote {len(data)} scenarios to {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
