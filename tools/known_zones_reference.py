"""How close to its zone-free run can a team that respects the known zones' keep-out discs
track? A reference for the "evade, then come back" ratios of docs/calibration.md §6.

Usage (from the repository root)::

    python tools/known_zones_reference.py                     # seeds 101..110
    python tools/known_zones_reference.py --seeds 1-10 --scenarios combined-temp

For each scenario and seed it runs the default failure-aware team three ways: as usual (zones
unknown until they strike), with every zone *known from the start* (each robot holds every
zone's attack clue, i.e. its prior ``μ, Σ, r``, at step 0; never its true centre), and with
``zones: []``. It prints the mean last-third ratio (mean trace over the final third ÷ the
zone-free run's) of the first two and the robots attacked per run. A team that knows every zone
from the start never has to learn or come back, so its ratio is what the keep-out discs alone
cost: a ratio target below it cannot be met by any team that respects the chance constraints.
"""

from __future__ import annotations

import argparse

import numpy as np
from comeback_table import SIX, seed_range  # tools/ is on the path when run as a script

from resilient_tracking import scenarios
from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.team import Team
from resilient_tracking.world import World


def episode(scenario: Scenario, seed: int, known: bool) -> tuple[float, int]:
    """Last-third mean trace and robots attacked of one failure-aware run."""

    def know_every_zone(world: World, team: Team) -> None:
        for zone in world.zones:
            estimate = ZoneEstimate.from_clue(zone.clue(), 0)
            for robot in range(world.n_robots):
                team.belief.knowledge[robot].learn(estimate)

    result = run_episode(scenario, "failure_aware", seed, setup=know_every_zone if known else None)
    trace = result["team"]["trace"].to_numpy()
    robots = result["robots"]
    hit = robots.groupby("robot")[["sensing_ok", "comm_ok"]].min()
    attacked = int(((hit["sensing_ok"] == 0) | (hit["comm_ok"] == 0)).sum())
    return float(trace[-len(trace) // 3 :].mean()), attacked


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="101-110")
    parser.add_argument("--scenarios", default=",".join(SIX))
    args = parser.parse_args()
    seeds = seed_range(args.seeds)
    print(
        "| scenario | last third ÷ no-zone: learned | known from the start | "
        "robots attacked: learned / known |"
    )
    print("|---|---|---|---|")
    for name in args.scenarios.split(","):
        scenario = load_scenario(scenarios.folder() / f"{name}.yaml")
        free = scenario.with_overrides(zones=[])
        learned, known, hit_learned, hit_known = [], [], [], []
        for seed in seeds:
            base, _ = episode(free, seed, False)
            value, hits = episode(scenario, seed, False)
            learned.append(value / base)
            hit_learned.append(hits)
            value, hits = episode(scenario, seed, True)
            known.append(value / base)
            hit_known.append(hits)
        print(
            f"| {name} | {np.mean(learned):.2f} | {np.mean(known):.2f} | "
            f"{np.mean(hit_learned):.1f} / {np.mean(hit_known):.1f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
