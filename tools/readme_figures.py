"""Re-make the README's figures from real runs (``python tools/readme_figures.py``).

Each figure is one ``rtrack run`` of a shipped scenario, drawn from its run folder by the
package's own per-run figures, then copied to ``docs/images/``.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from resilient_tracking.cli import main as rtrack
from resilient_tracking.viz import METRICS_FILE, TRAJECTORY_FILE

IMAGES = Path(__file__).resolve().parents[1] / "docs" / "images"

#: (image name, rtrack run arguments, which figure of the run)
FIGURES = [
    ("sensing-perm-vanilla-map.png", ["sensing-perm", "--policy", "vanilla"], TRAJECTORY_FILE),
    ("sensing-temp-vanilla-metrics.png", ["sensing-temp", "--policy", "vanilla"], METRICS_FILE),
    (
        "sensing-perm-failure-aware-map.png",
        ["sensing-perm", "--policy", "failure_aware"],
        TRAJECTORY_FILE,
    ),
    (
        "sensing-temp-failure-aware-metrics.png",
        ["sensing-temp", "--policy", "failure_aware"],
        METRICS_FILE,
    ),
]


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for k, (name, args, figure) in enumerate(FIGURES):
            out = Path(tmp) / str(k)
            if rtrack(["run", *args, "--seed", "1", "--out", str(out), "-q"]) != 0:
                raise SystemExit(f"rtrack run {' '.join(args)} failed")
            shutil.copyfile(out / "figures" / figure, IMAGES / name)
            print(f"wrote {IMAGES / name}")


if __name__ == "__main__":
    main()
