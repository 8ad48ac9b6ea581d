"""Surging targets: a cue of the lure guard (docs/model.md §6.1).

A lure leaves its route for the danger at a speed of its own and comes back to it later. Seen
from the league's estimate, a target that had kept a steady course speeds up well beyond its
usual speed; a target that turns a corner keeps its speed, and one that flees robots was not on
a steady course before. So, per target, from the velocity over the lure guard's window:

* its **usual** speed and velocity are running means with time constant ``usual_memory``, and
  its **unsteadiness** the running mean of how far each velocity lies from the usual one. A
  tick more than ``surge / 2`` faster than usual is left out of all three, so neither a lure
  that sets off while it is still being watched nor one whose speed over the window rises
  slowly makes its trip speed its usual one;
* it **surges** once its speed has stayed more than ``surge`` above the usual speed for
  ``surge_steps`` ticks, if it was steady (unsteadiness at most ``steady``) and has been
  watched for ``usual_memory`` at least;
* the surge **ends** once its speed has stayed within ``surge / 2`` of the usual speed for
  ``calm_steps`` ticks: a lure back on its route. Stopping at the danger, or heading back at
  its own speed, keeps it surging.

Only ticks with a trusted velocity (a confident position estimate) count. Each robot keeps its
own record; a league takes, per target, that of the member that watched it longest, and a
surge any member saw. A target that speeds up for good, or stops for good at the end of its
route, stays suspect.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from resilient_tracking.policies.guards.lure_params import LureGuardParams


class SurgeWatch:
    """Per robot and target: usual speed and velocity, unsteadiness, ticks watched, the count
    towards a surge or its end, surging (module docstring)."""

    def __init__(self, n_robots: int, params: LureGuardParams, dt: float):
        self.params = params
        self.n_robots = n_robots
        self.dt = dt
        self._resize(0)

    def observe(self, robots: list[int], velocity: np.ndarray, trusted: np.ndarray) -> np.ndarray:
        """Update ``robots``' (one league's) record with each target's ``velocity`` ``(N, 2)``
        over the window, where ``trusted``; returns which targets started a surge now."""
        if self.surging.shape[1] != len(velocity):
            self._resize(len(velocity))
        p, members = self.params, np.asarray(robots)
        # per target, the record of the member that watched it longest; surging if any member
        # saw it surge (a league merging keeps a surge)
        cols = np.arange(len(velocity))
        keeper = members[np.argmax(self.watched[members], axis=0)]
        usual, usual_velocity = self.usual[keeper, cols], self.usual_velocity[keeper, cols]
        unsteady, watched = self.unsteady[keeper, cols], self.watched[keeper, cols]
        count, surging = self.count[keeper, cols], self.surging[members].any(axis=0)
        count = np.where(surging == self.surging[keeper, cols], count, 0)
        rate = self.dt / p.usual_memory  # of the running means

        velocity = np.where(trusted[:, None], velocity, 0.0)  # (NaN before the window fills)
        speed = np.linalg.norm(velocity, axis=1)
        new = trusted & np.isnan(usual)
        usual[new], usual_velocity[new], unsteady[new] = speed[new], velocity[new], 0.0
        seen = trusted & ~new
        watched[trusted] += 1

        # half a surge faster than usual: left out of the running means (so a slow speed-up is
        # not taken in); a surge faster: a tick towards a surge for a steady, watched target
        faster = seen & ~surging & (speed > usual + p.surge / 2)
        rising = (
            faster
            & (speed > usual + p.surge)
            & (watched * self.dt >= p.usual_memory)
            & (unsteady <= p.steady)
        )
        usual_tick = seen & ~surging & ~faster  # (the running means follow it)
        drift = np.linalg.norm(velocity - usual_velocity, axis=1)
        unsteady = np.where(usual_tick, unsteady + rate * (drift - unsteady), unsteady)
        usual = np.where(usual_tick, usual + rate * (speed - usual), usual)
        usual_velocity = np.where(
            usual_tick[:, None], usual_velocity + rate * (velocity - usual_velocity), usual_velocity
        )
        # a surging target back at its usual speed: a tick towards the surge's end
        calm = seen & surging & (np.abs(speed - usual) < p.surge / 2)
        count = np.where(rising | calm, count + 1, np.where(seen, 0, count))
        started = rising & (count >= p.surge_steps)
        ended = calm & (count >= p.calm_steps)
        surging = (surging | started) & ~ended
        count = np.where(started | ended, 0, count)

        self.usual[robots], self.usual_velocity[robots] = usual, usual_velocity
        self.unsteady[robots], self.watched[robots] = unsteady, watched
        self.count[robots], self.surging[robots] = count, surging
        return started

    def _resize(self, n: int) -> None:
        m = self.n_robots
        #: ``(M, N)`` per robot and target (``usual_velocity`` ``(M, N, 2)``)
        self.usual = np.full((m, n), np.nan)
        self.usual_velocity = np.zeros((m, n, 2))
        self.unsteady = np.zeros((m, n))
        self.watched = np.zeros((m, n), dtype=int)
        self.count = np.zeros((m, n), dtype=int)
        self.surging = np.zeros((m, n), dtype=bool)
