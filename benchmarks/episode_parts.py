"""Where an episode's time goes, per step: observation, belief, the policy outside its solver,
planning (the solver ladder), the world's step and the records; before and after a change,
side by side in one run.

    python -m benchmarks.episode_parts                      # this checkout
    python -m benchmarks.episode_parts --before ../main/src # and another source tree, alternately
    python -m benchmarks.episode_parts --quick              # bench-risk failure-aware only

Each case (``bench-risk`` seed 4, 4 robots × 4 targets, 300 steps, the paper's one-step program)
runs once untimed (imports, compiled code), then ``--repeats`` times; with ``--before`` every
round runs the other tree's code and this one's in fresh processes, one after the other, so
both see the same machine load. Times are medians over the rounds, in ms per step; *outside
planning* is the episode's wall time less the solver ladder's (``timing.parquet``'s
``plan_ms``), as in ``benchmarks/programs.py``.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

CASES = (("bench-risk", "failure_aware", 4), ("bench-risk", "vanilla", 4), ("bench-risk", "sog", 4))
PARTS = ("observe", "belief", "policy", "planning", "world", "records")


def measure(name: str, policy: str, seed: int) -> dict[str, float]:
    """One episode, timed part by part (ms per step); the loop of ``run_episode``."""
    from resilient_tracking import builtin_scenarios
    from resilient_tracking.runs.records import join_tables
    from resilient_tracking.runs.team_recorder import TeamRecorder
    from resilient_tracking.runs.truth_recorder import TruthRecorder
    from resilient_tracking.scenario import load_scenario
    from resilient_tracking.team import TeamStep, build_team
    from resilient_tracking.world import World

    scenario = load_scenario(builtin_scenarios.folder() / f"{name}.yaml")
    data = scenario.model_dump(mode="python")
    if "program" in data.get("planner", {}):
        data["planner"]["program"] = "one_step"
    scenario = type(scenario).model_validate(data)
    clock = time.perf_counter
    spent = dict.fromkeys(PARTS, 0.0)
    start = clock()
    world = World(scenario, seed)
    team = build_team(scenario, policy, seed, world.target_states)
    team_rows = TeamRecorder(world.n_robots, len(world.targets), scenario.steps)
    truth_rows = TruthRecorder(len(world.targets), scenario.steps, world.zones)
    for _ in range(scenario.steps):
        a = clock()
        obs = world.observe()
        truth = world.target_states
        b = clock()
        events = team.belief.update(obs)
        c = clock()
        decision = team.policy.act(team.belief, obs)
        d = clock()
        out = TeamStep(decision.controls, decision, events + decision.events)
        applied = world.step(out.controls)
        e = clock()
        team_rows.step(obs, out, applied, team.belief)
        estimate = team.belief.team_estimate()
        truth_rows.step(obs.step, truth[:, :2], estimate.mean[:, :2], estimate.cov[:, :2, :2])
        f = clock()
        plan = decision.plan_ms / 1e3
        for part, seconds in zip(
            PARTS, (b - a, c - b, d - c - plan, plan, e - d, f - e), strict=True
        ):
            spent[part] += seconds
    g = clock()
    join_tables(team_rows.tables(), truth_rows.tables())
    spent["records"] += clock() - g
    wall = clock() - start
    steps = scenario.steps
    out_ms = {part: 1e3 * seconds / steps for part, seconds in spent.items()}
    out_ms["outside planning"] = 1e3 * (wall - spent["planning"]) / steps
    out_ms["episode (s)"] = wall
    return out_ms


def child(cases: list[list[Any]]) -> dict[str, Any]:
    """Run in a fresh process: every case once untimed, then once timed."""
    cases_ = [(str(n), str(p), int(seed)) for n, p, seed in cases]
    try:
        from resilient_tracking.planning.nlp_cache import wait_for_compilers
    except ImportError:  # pragma: no cover - an old tree
        wait_for_compilers = None  # type: ignore[assignment]
    for case in cases_:
        measure(*case)
    if wait_for_compilers is not None:
        wait_for_compilers()
    try:
        from resilient_tracking.planning.sog_nlp import wait_for_sog_compilers

        wait_for_sog_compilers()
    except ImportError:  # a tree before the SOG fast path
        pass
    return {"/".join(map(str, case)): measure(*case) for case in cases_}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    from benchmarks.common import machine, run_in_tree, save, table

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", help="source tree (the folder holding resilient_tracking)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="failure-aware only, 2 rounds")
    args = parser.parse_args(argv)
    cases = [list(c) for c in (CASES[:1] if args.quick else CASES)]
    repeats = 2 if args.quick else args.repeats
    trees = {"after": None} if args.before is None else {"before": args.before, "after": None}
    rounds: dict[str, list[dict[str, Any]]] = {label: [] for label in trees}
    for k in range(repeats):
        order = list(trees) if k % 2 == 0 else list(trees)[::-1]
        for label in order:
            timed = run_in_tree(trees[label], "benchmarks.episode_parts", "child", cases)
            rounds[label].append(timed)
    results: dict[str, Any] = {"machine": machine(), "before_tree": args.before, "cases": {}}
    for case in cases:
        key = "/".join(map(str, case))
        found = {
            label: {
                part: float(np.median([r[key][part] for r in rounds[label]]))
                for part in rounds[label][0][key]
            }
            for label in trees
        }
        results["cases"][key] = found
        rows = []
        for part in found["after"]:
            row: list[Any] = [part]
            if "before" in found:
                row += [found["before"][part], found["after"][part]]
                row.append(found["after"][part] / found["before"][part])
            else:
                row.append(found["after"][part])
            rows.append(row)
        header = (
            ["ms per step", "before", "after", "after ÷ before"]
            if "before" in found
            else [
                "ms per step",
                "this tree",
            ]
        )
        print(f"{key} (median of {repeats} rounds)\n" + table(rows, header) + "\n")
    save("episode_parts", results)
    return results


if __name__ == "__main__":
    main()
