"""Reference measurement: what the lure guard would save if the team knew which targets lure
(docs/adversarial.md, *The lure guard*).

The extended team (the adaptive estimator) with the lure guard, whose suspicion is replaced by
the truth: every lure target is suspect from the first tick (``always``); exactly while it is
on a trip into its zone or lingering there (``trip``); or while it is away from its base motion
at all, on the way there, lingering or on the way back (``voyage``). ``--latency`` starts the
suspicion of each trip or voyage that many seconds late, as a cue that must first see the
target leave its course would. Its league keeps ``standoff`` from a suspect target, as the
belief-only guard does. Reading the world is what makes it a reference: no cue from the team's
own estimate can know more.

    python tools/lure_oracle_reference.py lure-sensing lure-comm --seeds 1-10
    python tools/lure_oracle_reference.py lure-sensing --standoffs 1.0,1.5,2.0 --oracle voyage \
        --latency 2

Prints, per scenario, oracle and stand-off, the mean over seeds of the team trace, the MSE and
the permanent losses per run, beside the extended team without a guard.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np
from joblib import Parallel, delayed

from resilient_tracking import builtin_scenarios
from resilient_tracking.cli.common import MAX_SEEDS
from resilient_tracking.experiments.comparison import parse_seeds
from resilient_tracking.policies.guards.lure import LureGuard
from resilient_tracking.policies.guards.suspects import SuspectWatch
from resilient_tracking.scenario import load_scenario
from resilient_tracking.scenario.overrides import overridden
from resilient_tracking.sim.episode import EpisodeStepper
from resilient_tracking.world import World

GUARD = "guards.lure.enabled"
STANDOFF = "guards.lure.standoff"
#: the lure motion's modes per oracle: heading for the zone and holding there (a trip), and
#: heading back to the base motion as well (a voyage)
MODES = {"trip": ("go", "linger"), "voyage": ("go", "linger", "return")}
ORACLES = ("always", "trip", "voyage")


def _truth(world: World, oracle: str) -> np.ndarray:
    """Which targets the oracle suspects now (truth: this is what makes it a reference)."""
    if oracle == "always":
        return np.array([t.spec.motion.type == "lure" for t in world.targets])
    return np.array(
        [
            t.spec.motion.type == "lure" and getattr(t.motion, "mode", "") in MODES[oracle]
            for t in world.targets
        ]
    )


def _oracle(watch: SuspectWatch, world: World, oracle: str, latency: int) -> Any:
    """``watch.observe`` with its suspicion replaced by the truth after each call, each
    stretch of suspicion starting ``latency`` steps late."""
    observe = watch.observe
    since = np.full(len(world.targets), -1)  # the step each true stretch began (-1: none)

    def observed(step, robots, estimate, zone_rows):  # type: ignore[no-untyped-def]
        events = observe(step, robots, estimate, zone_rows)
        now = _truth(world, oracle)
        since[now & (since < 0)] = step
        since[~now] = -1
        watch.suspect[:, :] = (now & (step - since >= latency))[None, :]
        watch.surges.surging[:, :] = False  # (the guard's own cues make no difference)
        return events

    return observed


def run(
    name: str, seed: int, oracle: str, standoff: float | None, latency: float = 0.0
) -> dict[str, float]:
    """One episode; its mean trace, MSE and permanent losses."""
    # the paper's method on the route program with the adaptive estimator
    settings: dict[str, Any] = {"team": "route", "estimator.type": "adaptive"}
    if standoff is not None:
        settings |= {GUARD: True, STANDOFF: standoff}
    scenario = overridden(load_scenario(builtin_scenarios.resolve(name)), settings)
    stepper = EpisodeStepper(scenario, "failure_aware", seed)
    lure = [g for g in getattr(stepper.team.policy, "guards", []) if isinstance(g, LureGuard)]
    if lure:
        watch = lure[0].suspects
        late = round(latency / scenario.dt)
        watch.observe = _oracle(watch, stepper.world, oracle, late)  # type: ignore[method-assign]
    for _ in range(scenario.steps):
        stepper.sense()
        stepper.act()
    tables = stepper.result(0.0).tables
    events = tables["events"]
    attacks = events[events["event"].astype(str) == "attack"]
    losses = int((attacks["persistence"].astype(str) == "permanent").sum())
    team = tables["team"]
    return {"trace": float(team.trace.mean()), "mse": float(team.mse.mean()), "losses": losses}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scenarios", nargs="+", help="shipped names or scenario files")
    parser.add_argument("--seeds", default="1-10", help="A-B (default 1-10)")
    parser.add_argument("--standoffs", default="1.5,2.0,2.5", help="comma-separated, m")
    parser.add_argument("--oracle", choices=(*ORACLES, "all"), default="all")
    parser.add_argument(
        "--latency", type=float, default=0.0, help="s from a trip's start to its suspicion"
    )
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    seeds = parse_seeds(args.seeds, MAX_SEEDS)
    oracles = ORACLES if args.oracle == "all" else (args.oracle,)
    cases: list[tuple[str, float | None]] = [("none", None)]
    cases += [(o, float(s)) for o in oracles for s in args.standoffs.split(",")]
    late = f", {args.latency:g} s late" if args.latency else ""
    print("| scenario | suspects | stand-off (m) | trace | MSE | permanent losses per run |")
    print("|---|---|---|---|---|---|")
    for name in args.scenarios:
        for oracle, standoff in cases:
            rows = Parallel(n_jobs=args.jobs)(
                delayed(run)(name, seed, oracle, standoff, args.latency) for seed in seeds
            )
            mean = {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}
            who = "no guard" if standoff is None else f"every lure, {oracle}{late}"
            shown = "–" if standoff is None else f"{standoff:g}"
            print(
                f"| {name} | {who} | {shown} | {mean['trace']:.4f} | {mean['mse']:.4f} | "
                f"{mean['losses']:.2f} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
