"""The one declaration of every run table: its rows, and each column's name, dtype, unit, meaning.

The recorders build their columns from it, :func:`~resilient_tracking.runs.reading.load_run`
and the check of stored runs test folders against it, and the README's run-folder table is
generated from it (:mod:`resilient_tracking.runs.reference`).

Each column says which recorder writes it: ``team`` (what the robots know or did:
:class:`~resilient_tracking.runs.team_recorder.TeamRecorder`) or ``truth`` (the world's truth
and the error against it: :class:`~resilient_tracking.runs.truth_recorder.TruthRecorder`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd

from resilient_tracking.events import EVENT_NAMES, TRUTH_EVENTS

Dtype = Literal["int64", "float64", "bool", "str"]
Side = Literal["team", "truth"]

#: NumPy storage of each declared dtype while a table is recorded (text as Python objects).
NUMPY_DTYPES: dict[str, Any] = {
    "int64": np.int64,
    "float64": np.float64,
    "bool": np.bool_,
    "str": object,
}


@dataclass(frozen=True)
class Column:
    """One column: name, dtype, unit (``""`` when it has none), one-line meaning, recorder."""

    name: str
    dtype: Dtype
    unit: str
    meaning: str
    side: Side = "team"


@dataclass(frozen=True)
class Table:
    """One table of a run folder (``<name>.parquet``)."""

    name: str
    #: what one row is
    rows: str
    columns: tuple[Column, ...]
    #: columns both recorders write, which pair their rows (their values must agree)
    keys: tuple[str, ...] = ("step",)
    #: identical, bit for bit, for the same scenario and seed (only ``timing`` is not)
    reproducible: bool = True
    #: may be absent from a run folder (then read as empty)
    optional: bool = False
    #: a remark for the README row
    note: str = ""
    #: besides the team's rows, truth appends rows of its own (events only the world knows)
    truth_rows: bool = False

    @property
    def file(self) -> str:
        """The table's file in a run folder."""
        return f"{self.name}.parquet"

    @property
    def names(self) -> list[str]:
        """Column names, in order."""
        return [c.name for c in self.columns]

    def column(self, name: str) -> Column:
        """The column called ``name``; ``KeyError`` if the table has none."""
        for c in self.columns:
            if c.name == name:
                return c
        raise KeyError(f"{self.name} has no column {name!r}")

    def side_names(self, side: Side) -> list[str]:
        """The columns ``side`` records: its own and the keys, in table order."""
        return [c.name for c in self.columns if c.side == side or c.name in self.keys]

    def numpy_dtypes(self, side: Side | None = None) -> dict[str, Any]:
        """Column name → NumPy dtype, of every column or of those ``side`` records."""
        names = self.names if side is None else self.side_names(side)
        return {n: NUMPY_DTYPES[self.column(n).dtype] for n in names}

    def empty_frame(self) -> pd.DataFrame:
        """The table with no rows: every declared column, of dtype ``object``.

        (Tables recorded row by row have always been written so when empty; the fixed-size
        per-step tables keep their dtypes.)
        """
        return pd.DataFrame({c: pd.Series(dtype="object") for c in self.names})


def _c(name: str, dtype: Dtype, unit: str, meaning: str, side: Side = "team") -> Column:
    return Column(name, dtype, unit, meaning, side)


_STEP = _c("step", "int64", "", "tick index k (time = k·dt)")

TEAM = Table(
    "team",
    "one per step",
    (
        _STEP,
        _c("time", "float64", "s", "time of the step"),
        _c(
            "mse", "float64", "m²", "(1/N) Σ_j ‖ŷ_j − y_j‖² of the team estimate, vs truth", "truth"
        ),
        _c(
            "nll",
            "float64",
            "nats",
            "(1/N) Σ_j Gaussian NLL of the true position y_j under N(ŷ_j, P_j), vs truth",
            "truth",
        ),
        _c(
            "nees",
            "float64",
            "",
            "(1/N) Σ_j (ŷ_j − y_j)ᵀ P_j⁻¹ (ŷ_j − y_j), position NEES (2 when consistent)",
            "truth",
        ),
        _c("trace", "float64", "m²", "Σ_j tr P_j of the team estimate's position blocks"),
        _c("effort", "float64", "m/s", "Σ_i ‖u_i‖ of the applied velocities"),
        _c("n_sensing_failed", "int64", "", "robots whose sensor is down"),
        _c("n_comm_failed", "int64", "", "robots whose radio is down"),
        _c("n_leagues", "int64", "", "leagues (connected groups of robots)"),
        _c("n_solves", "int64", "", "league plans made this step"),
        _c("n_solver_failures", "int64", "", "plans that did not succeed"),
        _c("solver_iterations", "int64", "", "solver iterations summed over the plans"),
    ),
)

TIMING = Table(
    "timing",
    "one per step",
    (_STEP, _c("plan_ms", "float64", "ms", "wall time of planning")),
    reproducible=False,
    note="the only table that differs between two runs of the same seed",
)

ROBOTS = Table(
    "robots",
    "one per robot per step",
    (
        _STEP,
        _c("robot", "int64", "", "robot index"),
        _c("x", "float64", "m", "position"),
        _c("y", "float64", "m", "position"),
        _c("ux", "float64", "m/s", "velocity applied from step k to k+1"),
        _c("uy", "float64", "m/s", "velocity applied from step k to k+1"),
        _c("sensing_ok", "bool", "", "the robot can sense"),
        _c("comm_ok", "bool", "", "the robot's radio works"),
        _c("league", "int64", "", "index of the robot's league"),
        _c("mode", "str", "", "league, cooldown, individual, circular or idle"),
    ),
    keys=("step", "robot"),
)

TARGETS = Table(
    "targets",
    "one per target per step",
    (
        _STEP,
        _c("target", "int64", "", "target index"),
        _c("x", "float64", "m", "true position", "truth"),
        _c("y", "float64", "m", "true position", "truth"),
        _c("est_x", "float64", "m", "team estimate of the position"),
        _c("est_y", "float64", "m", "team estimate of the position"),
        _c("var_x", "float64", "m²", "variance of est_x"),
        _c("var_y", "float64", "m²", "variance of est_y"),
        _c("cov_xy", "float64", "m²", "covariance of est_x and est_y"),
    ),
    keys=("step", "target"),
)

EVENTS = Table(
    "events",
    "one per event",
    (
        _STEP,
        _c("robot", "int64", "", "robot concerned, −1 for the team or a league"),
        _c(
            "event",
            "str",
            "",
            "name (resilient_tracking.events.EventName); "
            + " and ".join(TRUTH_EVENTS)
            + " rows are truth's, never seen by the team",
        ),
        _c("detail", "str", "", "one line for people (never parsed)"),
        _c(
            "kind",
            "str",
            "",
            "sensing or comm (attack, recover, zone_*, degradation_detected), else empty",
        ),
        _c("zone", "int64", "", "id of the zone that attacked or was learned, −1 when none"),
        _c("persistence", "str", "", "temporary, permanent (unknown: zone_learned), else empty"),
        _c(
            "cause",
            "str",
            "",
            "attack: hazard (the zone's draw), jamming, degradation (announced) or spread (a"
            " teammate's compromised radio passed the zone's compromise on); degraded:"
            " announced or silent; invalid_decision: what was wrong"
            " (not_finite, out_of_bounds, shape, type, modes, events, plans);"
            " target_suspected: surge, linger or zone; else empty",
        ),
        _c(
            "source",
            "str",
            "",
            "zone_*: attack, broadcast, circle, silence or degradation;"
            " degradation_detected: degradation; else empty",
        ),
        _c("fallback", "str", "", "solver_fallback: the rung taken (safe, ...), else empty"),
        _c(
            "action",
            "str",
            "",
            "solver_fallback to safe: escape or hold; invalid_decision and pose_lost: hold;"
            " else empty",
        ),
        _c("status", "str", "", "solver_fallback: the planner's status, else empty"),
    ),
    optional=True,
    note="events: " + ", ".join(EVENT_NAMES),
    truth_rows=True,
)

ZONES = Table(
    "zones",
    "one per zone",
    (
        _c("zone", "int64", "", "zone id", "truth"),
        _c("name", "str", "", "the scenario's name for it (else S<id>/C<id>)", "truth"),
        _c("kind", "str", "", "sensing or comm", "truth"),
        _c("persistence", "str", "", "temporary or permanent", "truth"),
        _c("mu_x", "float64", "m", "prior mean of the centre", "truth"),
        _c("mu_y", "float64", "m", "prior mean of the centre", "truth"),
        _c("sigma_xx", "float64", "m²", "prior covariance of the centre", "truth"),
        _c("sigma_xy", "float64", "m²", "prior covariance of the centre", "truth"),
        _c("sigma_yy", "float64", "m²", "prior covariance of the centre", "truth"),
        _c("size", "float64", "m or –", "sensing: radius r; comm: jamming strength δ2", "truth"),
        _c("true_x", "float64", "m", "drawn true centre", "truth"),
        _c("true_y", "float64", "m", "drawn true centre", "truth"),
    ),
    keys=(),
    note="truth, for plots only, never seen by robots",
)

ZONE_TRACKS = Table(
    "zone_tracks",
    "one per moving zone and step",
    (
        _c("step", "int64", "", "time step", "truth"),
        _c("zone", "int64", "", "zone id", "truth"),
        _c("mu_x", "float64", "m", "prior mean of the centre at this step", "truth"),
        _c("mu_y", "float64", "m", "prior mean of the centre at this step", "truth"),
        _c("true_x", "float64", "m", "true centre at this step", "truth"),
        _c("true_y", "float64", "m", "true centre at this step", "truth"),
    ),
    keys=(),
    optional=True,
    note="truth, for plots only, never seen by robots; empty when no zone moves",
)

BOUND = Table(
    "bound",
    "one per step, when the bound is asked for",
    (
        _c("step", "int64", "", "time step", "truth"),
        _c(
            "bound",
            "float64",
            "m²",
            "(1/N) Σ_j tr of the posterior Cramér–Rao bound of target j's position",
            "truth",
        ),
    ),
    keys=(),
    optional=True,
    note="truth, never seen by robots; empty unless asked for (rtrack run --bound)",
)

KNOWLEDGE = Table(
    "knowledge",
    "one per zone estimate learned",
    (
        _STEP,
        _c("robot", "int64", "", "robot that learned it"),
        _c("zone", "int64", "", "zone id when learned from an attack clue, −1 when inferred"),
        _c("kind", "str", "", "sensing or comm"),
        _c("source", "str", "", "attack, broadcast, circle, silence or degradation"),
        _c("x", "float64", "m", "estimated centre"),
        _c("y", "float64", "m", "estimated centre"),
        _c("sigma_xx", "float64", "m²", "covariance of the centre"),
        _c("sigma_xy", "float64", "m²", "covariance of the centre"),
        _c("sigma_yy", "float64", "m²", "covariance of the centre"),
        _c("size", "float64", "m or –", "sensing: radius r; comm: jamming strength δ2"),
    ),
    optional=True,
)

#: Every table of a run folder, by name, in the order they are written.
TABLES: dict[str, Table] = {
    t.name: t for t in (TEAM, ROBOTS, TARGETS, EVENTS, ZONES, ZONE_TRACKS, KNOWLEDGE, BOUND, TIMING)
}
#: Tables that are identical, bit for bit, for the same scenario and seed.
REPRODUCIBLE: tuple[str, ...] = tuple(n for n, t in TABLES.items() if t.reproducible)
#: Table files every run folder holds.
TABLE_FILES: tuple[str, ...] = tuple(t.file for t in TABLES.values())
#: Every table a run folder holds, in the order they are written.
ALL_TABLES: tuple[str, ...] = tuple(TABLES)
