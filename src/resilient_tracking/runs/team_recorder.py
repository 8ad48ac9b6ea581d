"""The team's side of a run's tables: what the robots know, did and decided, step by step.

It reads only what a team has (its observations, its belief, its commands), never truth, so a
node on robots records with it as the simulator does. Truth's columns come from
:class:`~resilient_tracking.runs.truth_recorder.TruthRecorder`; the two are joined per table
by :func:`~resilient_tracking.runs.records.join_sides`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.runs.metrics import effort
from resilient_tracking.runs.records import ColumnTable
from resilient_tracking.runs.schema import EVENTS, KNOWLEDGE, ROBOTS, TARGETS, TEAM, TIMING
from resilient_tracking.team import TeamStep


class TeamRecorder:
    """Rows of the team's columns of every table, as compact columns (see ``ColumnTable``)."""

    def __init__(self, n_robots: int, n_targets: int, steps: int):
        self.team = ColumnTable(TEAM.numpy_dtypes("team"), steps)
        self.robots = ColumnTable(ROBOTS.numpy_dtypes("team"), steps * n_robots)
        self.targets = ColumnTable(TARGETS.numpy_dtypes("team"), steps * n_targets)
        self.timing = ColumnTable(TIMING.numpy_dtypes("team"), steps)
        self.events = ColumnTable(EVENTS.numpy_dtypes("team"))
        self.knowledge = ColumnTable(KNOWLEDGE.numpy_dtypes("team"))

    def event(self, e: Event) -> None:
        """Record one event row (every field of :class:`Event` is a column)."""
        self.events.append_row(**{name: getattr(e, name) for name in EVENTS.names})

    def step(
        self, obs: TeamObservation, out: TeamStep, applied: np.ndarray, belief: TeamBelief
    ) -> None:
        """Record one tick: its events and the zones learned, the team row (trace, effort,
        failures, leagues, solver counts), its planning time, one row per robot, and the
        estimate and position covariance of every target."""
        k = obs.step
        for e in out.events:  # every event of the tick, attacks and learned zones included
            self.event(e)
        for robot, z in belief.learned:
            self.knowledge.append_row(
                step=k,
                robot=robot,
                zone=z.zone_id if z.zone_id is not None else -1,
                kind=z.kind,
                source=z.source,
                x=z.mean[0],
                y=z.mean[1],
                sigma_xx=z.cov[0, 0],
                sigma_xy=z.cov[0, 1],
                sigma_yy=z.cov[1, 1],
                size=z.size,
            )
        est = belief.team_estimate()
        plans = out.decision.plans
        self.team.append_row(
            step=k,
            time=obs.time,
            trace=est.position_trace(),
            effort=effort(applied),
            n_sensing_failed=len(obs.sensing_ok) - int(np.count_nonzero(obs.sensing_ok)),
            n_comm_failed=len(obs.comm_ok) - int(np.count_nonzero(obs.comm_ok)),
            n_leagues=len(belief.leagues),
            n_solves=len(plans),
            n_solver_failures=sum(not p.success for p in plans),
            solver_iterations=sum(p.iterations for p in plans),
        )
        self.timing.append_row(step=k, plan_ms=out.decision.plan_ms)
        n = obs.n_robots
        self.robots.append(
            n,
            step=k,
            robot=np.arange(n),
            x=obs.positions[:, 0],
            y=obs.positions[:, 1],
            ux=applied[:, 0],
            uy=applied[:, 1],
            sensing_ok=obs.sensing_ok,
            comm_ok=obs.comm_ok,
            league=belief.league_of,
            mode=out.decision.modes,
        )
        var = np.diagonal(est.cov, axis1=1, axis2=2)
        n_targets = len(est.mean)
        self.targets.append(
            n_targets,
            step=k,
            target=np.arange(n_targets),
            est_x=est.mean[:, 0],
            est_y=est.mean[:, 1],
            var_x=var[:, 0],
            var_y=var[:, 1],
            cov_xy=est.cov[:, 0, 1],
        )

    def tables(self) -> dict[str, pd.DataFrame]:
        """The team's part of each table recorded so far (row-by-row tables: declared
        columns, all ``object``, while empty)."""
        return {
            "team": self.team.frame(),
            "robots": self.robots.frame(),
            "targets": self.targets.frame(),
            "events": self.events.frame() if len(self.events) else EVENTS.empty_frame(),
            "knowledge": self.knowledge.frame() if len(self.knowledge) else KNOWLEDGE.empty_frame(),
            "timing": self.timing.frame(),
        }
