"""One row per stored run, computed from its saved tables (docs/model.md §8 metrics)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from resilient_tracking.experiments.known_zones import losses_by_knowledge
from resilient_tracking.runs.bound import exact_for
from resilient_tracking.runs.metrics import anees_band
from resilient_tracking.runs.reading import RunData, attack_table


def survival_steps(team: pd.DataFrame, n_robots: int) -> int:
    """Steps until no robot can sense any more (the whole run when one survives)."""
    dead = team.index[team["n_sensing_failed"].to_numpy() >= n_robots]
    return int(team["step"].iloc[dead[0]]) if len(dead) else len(team)


#: A robot that can still sense but ends farther than this (m) from every target is a straggler.
STRAGGLER_DISTANCE = 1.5


def last_third_mean(team: pd.DataFrame, column: str = "trace") -> float:
    """Mean of ``column`` over the final third of the episode (at least its last step)."""
    n = max(1, len(team) // 3)
    return float(team[column].iloc[-n:].mean())


def final_positions(run: RunData) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The robots' and the targets' rows at their last recorded step."""
    robots = run.robots[run.robots["step"] == run.robots["step"].max()]
    targets = run.targets[run.targets["step"] == run.targets["step"].max()]
    return robots, targets


def stragglers(robots: pd.DataFrame, targets: pd.DataFrame, distance: float) -> pd.DataFrame:
    """Rows of the robots that can sense (``sensing_ok``) but are farther than ``distance``
    from every target (true positions ``x, y`` of the given rows)."""
    able = robots[robots["sensing_ok"].astype(bool)]
    if able.empty or targets.empty:
        return able.iloc[:0]
    gaps = np.hypot(
        able["x"].to_numpy()[:, None] - targets["x"].to_numpy()[None, :],
        able["y"].to_numpy()[:, None] - targets["y"].to_numpy()[None, :],
    )
    return able[gaps.min(axis=1) > distance]


def robots_lost(events: pd.DataFrame) -> int:
    """Robots whose sensor or radio a permanent zone destroyed (attack events marked so)."""
    if events.empty:
        return 0
    lost = events[(events["event"] == "attack") & (events["persistence"] == "permanent")]
    return int(lost["robot"].nunique())


def consistency(team: pd.DataFrame, n_targets: int) -> dict[str, Any]:
    """The run's ANEES (mean of the per-step position NEES), its 95 % χ² band for the run's
    ``steps × targets`` samples (:func:`~resilient_tracking.runs.metrics.anees_band`), and
    whether it lies inside."""
    anees = float(team["nees"].mean())
    low, high = anees_band(max(1, len(team) * n_targets))
    return {
        "anees": anees,
        "anees_low": low,
        "anees_high": high,
        "anees_in_band": bool(low <= anees <= high),
    }


def bound_exact(run: RunData) -> bool:
    """Whether every target of the run, as its manifest's scenario declares it, moves by the
    linear-Gaussian model the bound assumes (:func:`~resilient_tracking.runs.bound.exact_for`):
    its bound is a true bound, not an indicative one."""
    targets = run.scenario.get("targets", []) or []
    return exact_for([str((t.get("motion") or {}).get("type", "")) for t in targets])


def bound_summary(run: RunData) -> dict[str, Any]:
    """The run's mean bound, its efficiency (mean bound ÷ mean MSE: 1 for an estimator that
    meets the bound), and whether the bound is exact; NaN when the run has no bound."""
    if not len(run.bound):
        return {"bound": float("nan"), "efficiency": float("nan"), "bound_exact": False}
    bound = float(run.bound["bound"].astype(float).mean())
    return {
        "bound": bound,
        "efficiency": bound / float(run.team["mse"].mean()),
        "bound_exact": bound_exact(run),
    }


def scores_line(run: RunData) -> str:
    """One line of a run's scores for people: mean MSE, mean NLL, ANEES and its band, the
    bound's efficiency when computed, and the paper's mean trace."""
    team = run.team
    n_targets = int(run.targets["target"].nunique())
    c = consistency(team, n_targets)
    inside = "inside" if c["anees_in_band"] else "outside"
    line = (
        f"mean MSE {team['mse'].mean():.3g}, mean NLL {team['nll'].mean():.3g}, "
        f"ANEES {c['anees']:.3g} ({inside} its 95 % band [{c['anees_low']:.3g}, "
        f"{c['anees_high']:.3g}])"
    )
    b = bound_summary(run)
    if np.isfinite(b["bound"]):
        kind = "" if b["bound_exact"] else ", indicative: scripted targets"
        line += f", bound {b['bound']:.3g} (efficiency {b['efficiency']:.2f}{kind})"
    return line + f", mean trace {team['trace'].mean():.3g}"


def summarise_run(run: RunData) -> dict[str, Any]:
    """The summary row of one run: its experiment, variant, policy, seed and tags, team size, and
    metrics (mean MSE, NLL, ANEES with its band, the bound when computed, mean and final trace,
    failures, attacks, solver fallbacks, stragglers...)."""
    team, events = run.team, run.events
    attacks = attack_table(run)
    n_robots = int(run.robots["robot"].nunique())
    tags = run.manifest.get("tags", {}) or {}
    robots_end, targets_end = final_positions(run)
    fallbacks = events["event"] == "solver_fallback" if len(events) else pd.Series(dtype=bool)
    far = stragglers(robots_end, targets_end, STRAGGLER_DISTANCE)
    n_targets = int(run.targets["target"].nunique())
    return {
        "experiment": run.manifest.get("experiment", ""),
        "variant": run.manifest.get("variant", run.policy),
        "policy": run.policy,
        "seed": run.seed,
        **{f"tag_{k}": v for k, v in tags.items()},
        "robots": n_robots,
        "targets": n_targets,
        "steps": len(team),
        "mse": float(team["mse"].mean()),
        "nll": float(team["nll"].mean()),
        **consistency(team, n_targets),
        **bound_summary(run),
        "trace": float(team["trace"].mean()),
        "final_trace": float(team["trace"].iloc[-1]),
        "last_third_trace": last_third_mean(team),
        "effort": float(team["effort"].mean()),
        "sensing_attacks": int((attacks["kind"] == "sensing").sum()),
        "comm_attacks": int((attacks["kind"] == "comm").sum()),
        "robots_attacked": int(attacks["robot"].nunique()),
        "robots_lost": robots_lost(events),
        # sensors and radios lost to zones the robot knew, or did not, before (known_zones.py)
        **losses_by_knowledge(run),
        "sensing_failed_end": int(team["n_sensing_failed"].iloc[-1]),
        # shares of robot-steps spent without a working sensor and without a working radio
        "sensing_down_share": float(team["n_sensing_failed"].mean() / n_robots),
        "comm_down_share": float(team["n_comm_failed"].mean() / n_robots),
        "sensing_end": int(robots_end["sensing_ok"].astype(bool).sum()),
        "stragglers": len(far),
        # of them, robots whose radio a zone destroyed: they circle their attacker (Alg. 4)
        "stragglers_circling": int((far["mode"] == "circular").sum()) if "mode" in far else 0,
        "survival_steps": survival_steps(team, n_robots),
        "zones_inferred": int((events["event"] == "zone_inferred").sum()) if len(events) else 0,
        "solver_failures": int(team["n_solver_failures"].sum())
        if "n_solver_failures" in team
        else 0,
        "solver_fallbacks": int(np.sum(fallbacks)),
    }
