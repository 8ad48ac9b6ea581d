"""Losses to zones the attacked robot already knew, read from a run's saved tables.

A hazard attack (``cause == "hazard"``; jamming isolation aside) is a *loss* when it took a
sensor or radio that worked at the step before (a zone striking a robot whose radio is already
destroyed, as around the attacker it circles, costs nothing). It counts as *known* when the
attacked robot held an estimate of that zone before the step of the attack: an estimate with the
zone's id (learned from an attack clue or a broadcast, or from a hazard map), or an estimate of
the same kind without an id (inferred from a circle or a silence) within the zone's prior
spread of its prior mean (two standard deviations along its widest axis, plus its size). The
prior is what the zones table records for plots; the attack's truth is never an input to the
team, only to this accounting.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from resilient_tracking.runs.reading import RunData

#: The columns :func:`losses_by_knowledge` adds to a summary row.
COLUMNS = (
    "losses_known_permanent",
    "losses_unknown_permanent",
    "losses_known_temporary",
    "losses_unknown_temporary",
)


def _reach(zone: pd.Series) -> float:
    """How far (m) from a zone's prior mean an unnamed estimate of it may lie."""
    sigma = np.array([[zone["sigma_xx"], zone["sigma_xy"]], [zone["sigma_xy"], zone["sigma_yy"]]])
    return float(2.0 * np.sqrt(np.linalg.eigvalsh(sigma).max()) + zone["size"])


def hazard_attacks(run: RunData) -> pd.DataFrame:
    """The run's hazard attacks, ``step, robot, zone, kind, persistence``, each with ``known``
    (the attacked robot knew the zone before that step) and ``loss`` (it took a working sensor
    or radio), as the module docstring says."""
    ev = run.events
    if ev.empty:
        return pd.DataFrame(
            columns=["step", "robot", "zone", "kind", "persistence", "known", "loss"]
        )
    attacks = ev[(ev["event"] == "attack") & (ev["cause"] == "hazard")]
    attacks = attacks[["step", "robot", "zone", "kind", "persistence"]].reset_index(drop=True)
    know = run.knowledge
    zones = run.zones.set_index("zone") if not run.zones.empty else run.zones
    known = []
    for step, robot, zone_id, kind in zip(
        attacks["step"], attacks["robot"], attacks["zone"].astype(int), attacks["kind"], strict=True
    ):
        if know.empty:
            known.append(False)
            continue
        held = know[(know["robot"] == robot) & (know["step"] < step) & (know["kind"] == kind)]
        found = bool((held["zone"] == zone_id).any())
        unnamed = held[held["zone"] < 0]
        if not found and len(unnamed) and zone_id in zones.index:
            zone = zones.loc[zone_id]
            assert isinstance(zone, pd.Series)  # zone ids are unique
            gap = np.hypot(unnamed["x"] - zone["mu_x"], unnamed["y"] - zone["mu_y"])
            found = bool((gap <= _reach(zone)).any())
        known.append(found)
    attacks["known"] = np.array(known, dtype=bool)
    attacks["loss"] = _worked_before(run, attacks)
    return attacks


def _worked_before(run: RunData, attacks: pd.DataFrame) -> np.ndarray:
    """Whether each attack's capability (``kind``) worked at the step before it (the first
    step: it did)."""
    if attacks.empty or run.robots.empty:
        return np.ones(len(attacks), dtype=bool)
    robots = run.robots.set_index(["step", "robot"])
    out = []
    for step, robot, kind in zip(attacks["step"], attacks["robot"], attacks["kind"], strict=True):
        key = (int(step) - 1, int(robot))
        column = "sensing_ok" if kind == "sensing" else "comm_ok"
        out.append(bool(robots.at[key, column]) if key in robots.index else True)
    return np.array(out, dtype=bool)


def losses_by_knowledge(run: RunData) -> dict[str, int]:
    """The run's hazard losses counted by whether the zone was known and by persistence."""
    attacks = hazard_attacks(run)
    attacks = attacks[attacks["loss"].astype(bool)]
    out = {}
    for column in COLUMNS:
        _, knowledge, persistence = column.split("_")
        rows = attacks[
            (attacks["known"] == (knowledge == "known")) & (attacks["persistence"] == persistence)
        ]
        out[column] = len(rows)
    return out
