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
from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.layout import sensing_row, sensing_table
from resilient_tracking.policies.guards.base import Guard, GuardParams, register_guard
from resilient_tracking.spec import MAX_STEP_COUNT, Length, PositiveLength
from resilient_tracking.team_config import TeamConfig

if TYPE_CHECKING:
    from resilient_tracking.policies.failure_aware_params import FailureAwareParams

log = logging.getLogger(__name__)

#: ``since`` value of a robot not known compromised
UNKNOWN = -1


class QuarantineParams(GuardParams):
    """How long and how far robots keep out of radio range of a teammate known to carry a
    compromise."""

    steps: int = Field(
        0,
        ge=0,
        le=MAX_STEP_COUNT,
        description=(
            "Steps a quarantine lasts from when the compromise became known; 0, the default:"
            " the rest of the episode (a permanent compromise never heals)."
        ),
        json_schema_extra={"unit": "steps"},
    )
    margin: Length = Field(
        0.3,
        description=(
            "Added to the team's radio range: the keep-out disc around a quarantined robot has"
            " radius comm_range + margin."
        ),
        json_schema_extra={"unit": "m"},
    )
    position_std: PositiveLength = Field(
        0.05,
        description=(
            "Standard deviation given to a quarantined robot's observed position in its eq. 7c"
            " row (it moves between ticks)."
        ),
        json_schema_extra={"unit": "m"},
    )


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
        """Record this tick's announcements of compromised radios."""
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


@register_guard("quarantine")
class QuarantineGuard(Guard):
    """Keep out of radio range of teammates known compromised (module docstring)."""

    name = "quarantine"
    Params = QuarantineParams
    params: QuarantineParams

    def __init__(self, params: QuarantineParams, config: TeamConfig, method: FailureAwareParams):
        super().__init__(params, config, method)
        #: teammates known to carry a compromise, per robot
        self.watch = QuarantineWatch(config.n_robots, params, config.comm_range)

    def observe(self, obs: TeamObservation) -> None:
        """Record this tick's announcements of compromised radios."""
        self.watch.observe(obs)

    def league_rows(
        self,
        step: int,
        robots: list[int],
        estimate: TargetEstimate,
        predicted: TargetEstimate,
        zone_rows: np.ndarray,
        obs: TeamObservation,
        beta1: float,
    ) -> tuple[np.ndarray, list[Event]]:
        """A keep-out row per teammate the league keeps quarantined."""
        return self.watch.rows(robots, obs, beta1), []
