"""Reference measurement: what a team whose filter *knows* every degraded sensor's true noise
would report, against the default team and the ``beyond`` team (docs/beyond.md, *What the trace
targets ask*).

The default team keeps the nominal noise of a silently degraded sensor, so its covariance is
smaller than its errors (NEES far above 2) and its trace is small. The reference team is the
default team with the degradation watch, the watch replaced by an oracle: at every tick each
robot's noise scale is its true one (the square of the world's noise factor), found at the
degradation's onset, with the watch's zone clue and careful update; it has none of the ``beyond``
team's other options, so it differs from the default team only where a sensor is degraded.
Reading the world is what makes it a reference: no team can do better at knowing its noise.
With ``--known-zones`` every zone is also known from the start (a hazard map), so the team can
keep out of it.

    python tools/known_noise_reference.py sensing-degrade --seeds 1-10
    python tools/known_noise_reference.py sensing-degrade --seeds 1-10 --known-zones
    python tools/known_noise_reference.py --suite --seeds 1-2   # the stored beyond suite

Prints, per scenario, the mean over seeds of the team trace, the MSE and the position NEES
(``(x − x̂)²/σx² + (y − ŷ)²/σy²``, 2 for a consistent filter) of the three teams.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from typing import Any

import pandas as pd
from joblib import Parallel, delayed

from resilient_tracking import builtin_scenarios
from resilient_tracking.belief.degradation_watch import DegradationWatch
from resilient_tracking.cli.common import MAX_SEEDS
from resilient_tracking.experiments.comparison import parse_seeds
from resilient_tracking.experiments.generator import stored_beyond_suite
from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.scenario.overrides import every_zone_known, overridden
from resilient_tracking.sim.episode import EpisodeStepper
from resilient_tracking.world.degradation import Degradations

TEAMS = ("default", "beyond", "known noise")
WATCH = "belief.degradation_watch.enabled"


def _oracle(watch: DegradationWatch, truth: Degradations) -> Any:
    """``watch.observe`` replaced: each robot's noise scale is its true one from its onset."""

    def observe(belief, step, robots, prior, positions, measurements):  # type: ignore[no-untyped-def]
        events = []
        for row, robot in enumerate(robots):
            factor = truth.noise_factor(robot)  # truth: this is what makes it a reference
            if factor > 1.0:
                events += watch.adopt(belief, step, robot, positions[row], factor**2)
        return events

    return observe


def run(scenario: Scenario, team: str, seed: int, known_zones: bool) -> dict[str, float]:
    """One episode of ``team``; its mean trace, MSE and position NEES."""
    if team == "beyond":
        scenario = scenario.with_team("beyond")
    elif team == "known noise":
        scenario = overridden(scenario, {WATCH: True})
    if known_zones:
        scenario = every_zone_known(scenario)
    stepper = EpisodeStepper(scenario, "failure_aware", seed)
    watch = stepper.team.belief.degradation_watch
    if team == "known noise":
        assert watch is not None
        watch.observe = _oracle(watch, stepper.world.degradations)  # type: ignore[method-assign]
    for _ in range(scenario.steps):
        stepper.sense()
        stepper.act()
    tables = stepper.result(0.0).tables
    t, tm = tables["targets"], tables["team"]
    nees = ((t.x - t.est_x) ** 2 / t.var_x + (t.y - t.est_y) ** 2 / t.var_y).mean()
    return {"trace": float(tm.trace.mean()), "mse": float(tm.mse.mean()), "nees": float(nees)}


def _scenarios(args: argparse.Namespace) -> Iterator[Scenario]:
    if args.suite:
        yield from stored_beyond_suite()
    for name in args.scenarios:
        yield load_scenario(builtin_scenarios.resolve(name))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scenarios", nargs="*", help="shipped names or scenario files")
    parser.add_argument("--suite", action="store_true", help="the stored beyond suite")
    parser.add_argument("--seeds", default="1-10", help="a range, e.g. 1-10")
    parser.add_argument("--known-zones", action="store_true", help="every zone known at start")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    cases = [
        (scenario, team, seed)
        for scenario in _scenarios(args)
        for team in TEAMS
        for seed in parse_seeds(args.seeds, MAX_SEEDS)
    ]
    rows = Parallel(n_jobs=args.jobs)(
        delayed(run)(scenario, team, seed, args.known_zones) for scenario, team, seed in cases
    )
    frame = pd.DataFrame(
        [
            {"scenario": s.name, "team": team, "seed": seed, **row}
            for (s, team, seed), row in zip(cases, rows, strict=True)
        ]
    )
    means = frame.groupby(["scenario", "team"], sort=False)[["trace", "mse", "nees"]].mean()
    print(means.unstack("team").to_string(float_format=lambda v: f"{v:.4g}"))
    trace = frame.groupby(["scenario", "team"])["trace"].mean().unstack("team")
    below = int((trace["known noise"] > trace["default"]).sum())
    print(
        f"\nscenarios where the known-noise team's mean trace is above the default team's: "
        f"{below} of {len(trace)}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
