"""Suspect targets: targets a league believes may be luring robots into danger (docs/model.md §6.1).

From the league's target estimate only (never the world), a target becomes suspect when

* it **surges**: after keeping a steady course it speeds up well beyond its usual speed (a lure
  leaving its route; :mod:`~resilient_tracking.policies.guards.surge_watch`). This suspicion lasts
  until it is back at its usual speed;
* it **lingers**: its speed over the last ``window`` ticks (how far the mean of its estimated
  positions in the window's second half lies from that of its first half, over the time between
  them: the velocity estimate alone is too noisy) stays
  below ``linger_speed``, with a confident position estimate (largest standard deviation at
  most ``position_std``), for ``linger_steps`` consecutive ticks after it was once seen moving
  faster than ``moving_speed`` (a lure holds still where the danger is); or
* it stands **at a known zone**: its estimated position lies within ``zone_margin`` of the safe
  radius ``r_safe`` of a row of the league's sensing table (eq. 7c: a sensing zone, or a comm
  zone's hazard).

Suspicion for lingering or standing at a zone lasts the episode. Each robot keeps its own
record; a league shares its members' (a union, like zone knowledge), so a robot that leaves a
league keeps what it learned there.
Against each suspect target the league plans with one more eq. 7c row, a keep-out disc of
radius ``standoff`` centred at the target's predicted position with its position covariance,
which the route program's keep-out discs then include as well.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.events import Event
from resilient_tracking.planning.layout import SensingRow, sensing_row, sensing_table
from resilient_tracking.policies.guards.surge_watch import SurgeWatch

if TYPE_CHECKING:
    from resilient_tracking.policies.guards.lure_params import LureGuardParams


class SuspectWatch:
    """Per robot and target: recent estimated positions, seen moving, lingering steps, suspect
    (module docstring)."""

    def __init__(self, n_robots: int, params: LureGuardParams, dt: float):
        self.params = params
        self.n_robots = n_robots
        self.dt = dt
        #: ``(M, window + 1, N, 2)`` the league's last estimated target positions per robot,
        #: newest last (NaN before the first); sized at the first observation
        self.history = np.zeros((n_robots, params.window + 1, 0, 2))
        #: ``(M, N)`` per robot and target
        self.moved = np.zeros((n_robots, 0), dtype=bool)
        self.lingering = np.zeros((n_robots, 0), dtype=int)
        self.suspect = np.zeros((n_robots, 0), dtype=bool)
        #: the surge cue's own record
        self.surges = SurgeWatch(n_robots, params, dt)

    def observe(
        self, step: int, robots: list[int], estimate: TargetEstimate, zone_rows: np.ndarray
    ) -> list[Event]:
        """Update ``robots``' (one league's) record from its current ``estimate`` and its
        sensing-table ``zone_rows``; an event per robot for each target newly suspect."""
        n = len(estimate.mean)
        if self.suspect.shape[1] != n:
            self._resize(n)
        p = self.params
        # a league shares its members' records (the first member's recent positions)
        history = np.roll(self.history[robots[0]], -1, axis=0)
        history[-1] = estimate.mean[:, :2]
        moved = self.moved[robots].any(axis=0)
        lingering = self.lingering[robots].max(axis=0)
        known = self.suspect[robots].any(axis=0)

        with np.errstate(invalid="ignore"):
            half = (p.window + 1) // 2
            shift = history[-half:].mean(axis=0) - history[:half].mean(axis=0)
            velocity = shift / ((p.window + 1 - half) * self.dt)
            speed = np.linalg.norm(velocity, axis=1)
        spread = np.sqrt(np.linalg.eigvalsh(estimate.cov[:, :2, :2])[:, -1].clip(min=0.0))
        measured = np.isfinite(speed) & (spread <= p.position_std)
        by_surge = self.surges.observe(robots, velocity, measured)
        moved |= measured & (speed > p.moving_speed)
        slow = moved & measured & (speed < p.linger_speed)
        lingering = np.where(slow, lingering + 1, 0)
        by_linger = lingering >= p.linger_steps
        by_zone = self._at_zone(estimate.mean[:, :2], zone_rows)

        events = []
        for j in np.flatnonzero((by_linger | by_zone | by_surge) & ~known):
            cause = "linger" if by_linger[j] else "zone" if by_zone[j] else "surge"
            x, y = estimate.mean[j, :2]
            for i in robots:
                events.append(Event.target_suspected(step, i, int(j), cause, float(x), float(y)))
        self.history[robots] = history
        self.moved[robots] = moved
        self.lingering[robots] = lingering
        self.suspect[robots] = known | by_linger | by_zone
        return events

    def rows(self, robots: list[int], predicted: TargetEstimate, beta: float) -> np.ndarray:
        """Sensing-table rows (eq. 7c) keeping ``robots`` ``standoff`` from each target their
        league suspects, at its predicted position, with chance margin ``beta``."""
        if not self.suspect.shape[1]:
            return sensing_table()
        suspect = self.suspect[robots].any(axis=0) | self.surges.surging[robots].any(axis=0)
        targets = np.flatnonzero(suspect)
        return sensing_table(
            [
                sensing_row(
                    predicted.mean[j, :2],
                    predicted.cov[j, :2, :2],
                    r_safe=self.params.standoff,
                    beta=beta,
                )
                for j in targets
            ]
        )

    def _at_zone(self, positions: np.ndarray, zone_rows: np.ndarray) -> np.ndarray:
        """Which positions lie within ``zone_margin`` of the safe radius of a row of
        ``zone_rows`` (around its mean)."""
        if not len(zone_rows):
            return np.zeros(len(positions), dtype=bool)
        centers, radii = zone_rows[:, SensingRow.MEAN], zone_rows[:, SensingRow.R_SAFE]
        gaps = np.linalg.norm(positions[:, None, :] - centers[None, :, :], axis=2)
        return np.any(gaps <= radii[None, :] + self.params.zone_margin, axis=1)

    def _resize(self, n: int) -> None:
        m = self.n_robots
        self.history = np.full((m, self.params.window + 1, n, 2), np.nan)
        self.moved = np.zeros((m, n), dtype=bool)
        self.lingering = np.zeros((m, n), dtype=int)
        self.suspect = np.zeros((m, n), dtype=bool)
        self.surges = SurgeWatch(m, self.params, self.dt)
