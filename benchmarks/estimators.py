"""What each estimator costs the belief: milliseconds per step of the team's belief update
(prediction, measurement update, leagues) with the paper's EKF, the two-mode IMM and the
adaptive estimator (docs/model.md §4), side by side in one run.

    python -m benchmarks.estimators            # about a minute
    python -m benchmarks.estimators --quick    # a smoke run

Each case runs a failure-aware episode of a shipped scenario with one estimator, timing
``TeamBelief.update`` only; the planner's time is not counted (it reads the combined Gaussian
of every estimator, so it does not depend on which one). Every case runs once untimed
(imports, compiled code), then the cases alternate ``--repeats`` times so that all see the
same machine load; the figures are medians over the rounds, with the ratio to the EKF.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from benchmarks.common import machine, save, table

SCENARIOS = (("evasive-open", "3×3"), ("soak-20x20", "20×20"))
ESTIMATORS: dict[str, dict[str, Any]] = {
    "ekf": {"type": "ekf"},
    "imm": {"type": "imm"},
    "adaptive": {"type": "adaptive"},
}


def belief_ms(name: str, estimator: dict[str, Any], steps: int) -> float:
    """Mean milliseconds per step of the belief update in one episode of ``name``."""
    from resilient_tracking import builtin_scenarios
    from resilient_tracking.belief.team_belief import TeamBelief
    from resilient_tracking.scenario import load_scenario
    from resilient_tracking.scenario.world_specs import EstimatorSpec
    from resilient_tracking.sim.episode import EpisodeStepper

    scenario = load_scenario(builtin_scenarios.path(name))
    # the scenario's initial uncertainty (fields every estimator has), this estimator's own
    common = set(EstimatorSpec.model_fields) - {"type"}
    section = {**scenario.estimator.model_dump(include=common), **estimator}
    scenario = scenario.with_overrides(steps=steps, estimator=section)
    stepper = EpisodeStepper(scenario, "failure_aware", seed=1)
    spent = [0.0]
    update = TeamBelief.update

    def timed(self: TeamBelief, obs: Any) -> Any:
        start = time.perf_counter()
        try:
            return update(self, obs)
        finally:
            spent[0] += time.perf_counter() - start

    TeamBelief.update = timed  # type: ignore[method-assign]
    try:
        for _ in range(steps):
            stepper.sense()
            stepper.act()
    finally:
        TeamBelief.update = update  # type: ignore[method-assign]
    return 1e3 * spent[0] / steps


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    results: dict[str, dict[str, float]] = {}
    rows = []
    for name, size in SCENARIOS:
        steps = (30 if args.quick else 150) if size == "20×20" else (60 if args.quick else 300)
        for estimator in ESTIMATORS.values():  # untimed: imports, compiled problems
            belief_ms(name, estimator, min(steps, 20))
        rounds: dict[str, list[float]] = {label: [] for label in ESTIMATORS}
        for _ in range(repeats):
            for label, estimator in ESTIMATORS.items():
                rounds[label].append(belief_ms(name, estimator, steps))
        medians = {label: float(np.median(v)) for label, v in rounds.items()}
        results[name] = medians
        for label, ms in medians.items():
            rows.append([size, name, label, ms, ms / medians["ekf"]])
    print(table(rows, ["size", "scenario", "estimator", "belief ms per step", "× EKF"]))
    path = save("estimators", {"machine": machine(), "belief_ms_per_step": results})
    print(f"\nsaved {path}")


if __name__ == "__main__":
    main()
