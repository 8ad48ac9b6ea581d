"""Quarantine: keeping out of radio range of teammates known to carry a compromise
(docs/model.md §6.2).

A robot whose radio a permanent comm zone compromises feels the attack (its clue) and announces
it with its last message, heard by the robots linked to it at the tick before. Each of them
records the robot as *quarantined* from that step on; a league shares its members' records (a
union, like zone knowledge), so a robot that leaves a league keeps what it learned there. Against
each quarantined robot outside it, a league plans with one more eq. 7c row: a disc of radius
``comm_range + margin`` at the robot's observed position (positions are observable without
radio), with a small position spread and the risk level ``ε1``, so a compromise passed on over
links cannot reach the league. A quarantine lasts ``steps`` ticks, or the rest of the episode.

Announcements are the only source: a robot compromised while it had no link is not quarantined
(a teammate could still read its circling, Alg. 3, but the fitted zone does not say whose radio
is compromised). Without a radio range there is no range to keep out of: the watch makes no rows.
"""

from __future__ import annotations

import functools
import logging

import numpy as np

from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.layout import sensing_row, sensing_table
from resilient_tracking.policies.failure_aware_params import QuarantineParams

log = logging.getLogger(__name__)

#: ``since`` value of a robot not known compromised
UNKNOWN = -1


@functools.cache
def _warn_no_range() -> None:
    """Said once per process: a sweep that sets the quarantine on every scenario would say it
    once per run."""
    log.warning(
        "quarantine: a team with no radio range (comm_range) has no range to keep out of; "
        "the quarantine does nothing there (said once)"
    )


class QuarantineWatch:
    """Per robot: from which step it knows each teammate compromised (module docstring)."""

    def __init__(self, n_robots: int, params: QuarantineParams, comm_range: float | None):
        self.params = params
        self.radius = None if comm_range is None else comm_range + params.margin
        if self.radius is None:
            _warn_no_range()
        #: ``(M, M)`` step from which robot ``i`` knows robot ``q`` compromised, else UNKNOWN
        self.since = np.full((n_robots, n_robots), UNKNOWN, dtype=int)
        self._last_links = np.zeros((n_robots, n_robots), dtype=bool)

    def observe(self, obs: TeamObservation) -> None:
        """Record this tick's announcements: a permanent comm failure (hazard or spread), heard
        by the robots linked to its victim at the tick before."""
        for attack in obs.attacks:
            clue = attack.clue
            # jamming cuts links and a degradation leaves a radio lossy: neither compromises it
            if clue.kind != "comm" or clue.persistence != "permanent":
                continue
            if attack.cause in ("jamming", "degradation"):
                continue
            q = attack.robot
            heard = self._last_links[q] & (self.since[:, q] == UNKNOWN)
            self.since[heard, q] = obs.step
        self._last_links = np.array(obs.links, dtype=bool)

    def quarantined(self, robots: list[int], step: int) -> list[int]:
        """The robots outside ``robots`` (one league) it keeps quarantined at ``step``; shares
        the members' records among them."""
        known = self.since[robots]
        held = np.where(known == UNKNOWN, np.iinfo(int).max, known).min(axis=0)
        shared = np.where(held == np.iinfo(int).max, UNKNOWN, held)
        self.since[robots] = shared
        active = shared != UNKNOWN
        if self.params.steps:
            active &= step < shared + self.params.steps
        active[robots] = False
        return np.flatnonzero(active).tolist()

    def rows(self, robots: list[int], obs: TeamObservation, beta: float) -> np.ndarray:
        """Sensing-table rows (eq. 7c) keeping ``robots`` out of radio range (plus the margin)
        of each robot their league keeps quarantined, at its observed position."""
        quarantined = self.quarantined(robots, obs.step)
        if self.radius is None or not quarantined:
            return sensing_table()
        cov = self.params.position_std**2 * np.eye(2)
        return sensing_table(
            [sensing_row(obs.positions[q], cov, r_safe=self.radius, beta=beta) for q in quarantined]
        )
