"""Comm zones learned from silent teammates (the paper's Alg. 3, EstimateCircleParameters).

Robots that still have links watch the ones without: a teammate that falls silent within radio
range suggests a jammer where it is (a provisional comm zone, beyond Alg. 3:
:class:`ProvisionalZoneSettings`), and a silent robot seen circling (CircularEvasionMode, Alg. 4)
tells where its attacker is: the fitted circle becomes a comm zone estimate. Both are learned by
every listener; the league shares them from the next tick on like any other knowledge.

The team's belief runs this watch at the end of its update when the policy needs it
(:class:`~resilient_tracking.belief.needs.BeliefNeeds`), with the belief's own settings
(:class:`~resilient_tracking.belief.settings.BeliefSettings`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, cast

import numpy as np
from pydantic import Field

from resilient_tracking.belief.circle_fit import CircleFitSettings, CircleWatcher, zone_from_circle
from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.spec import MAX_POSITION_STD, Strict


class ProvisionalZoneSettings(Strict):
    """A provisional comm zone where a teammate within radio range falls silent, until a circle
    fit replaces it (docs/model.md §10.1)."""

    enabled: bool = Field(
        True, description="Whether listeners learn a provisional comm zone where one falls silent."
    )
    std: float = Field(
        0.3,
        gt=0,
        le=MAX_POSITION_STD,
        description="Spread of the provisional comm zone's centre.",
        json_schema_extra={"unit": "m"},
    )


class LearningBelief(Protocol):
    """What the watch asks of the team's belief (``TeamBelief``): a league's shared knowledge,
    and a way to add what it inferred."""

    def league_knowledge(self, league: list[int]) -> KnowledgeBase:
        """The knowledge the members of ``league`` share."""
        ...

    def learn(self, robot: int, estimate: ZoneEstimate) -> None:
        """Add what ``robot`` inferred; shared at the next tick."""
        ...


@dataclass(frozen=True)
class SilentRobotSettings:
    """How silent robots are read: the belief's settings and how the team's robots circle."""

    #: when a silent robot is watched and its path counts as a circle (Alg. 3)
    circle_fit: CircleFitSettings
    #: the provisional zone where a teammate falls silent
    provisional_zone: ProvisionalZoneSettings
    #: chance-constraint margin β2 of the evasion circle (eq. 7d at risk level ε2)
    beta2: float
    #: margin the evading robot added to its circle radius
    circle_margin: float
    #: radio range (m) of the team, ``None`` for unlimited
    comm_range: float | None


class SilentRobotWatch:
    """Per-team state of the watch: each robot's recent silent positions."""

    def __init__(self, settings: SilentRobotSettings):
        self.settings = settings
        self.watcher = CircleWatcher(settings.circle_fit)
        #: robots that had no link at the last tick
        self._silent: set[int] = set()

    def observe(self, belief: LearningBelief, obs: TeamObservation) -> list[Event]:
        """Watch this tick's silent robots; learn what they reveal; one event per finding."""
        s = self.settings
        events: list[Event] = []
        # (the ufunc's reduction itself: ndarray.any's Python wrapper costs more than it does)
        linked = cast(list[bool], np.logical_or.reduce(obs.links, axis=1).tolist())
        if not self._silent and all(linked):  # the usual tick: nobody to watch, nobody to forget
            return []  # (the watcher keeps a robot only while it is silent, as it was last tick)
        listeners = [i for i, has_link in enumerate(linked) if has_link]
        for robot, has_link in enumerate(linked):
            silent = not has_link
            if silent and robot not in self._silent and listeners:
                events += self._suspect_jammer(belief, obs, robot, listeners)
            fit = self.watcher.observe(robot, obs.positions[robot], silent)
            if fit is None or not listeners:
                continue
            zone = zone_from_circle(
                fit,
                robot,
                obs.step,
                delta2=s.circle_fit.inferred_delta2,
                beta2=s.beta2,
                margin=s.circle_margin,
            )
            for i in listeners:
                belief.learn(i, zone)
            events.append(
                Event.zone_inferred(
                    obs.step, robot, fit.center, fit.radius, fit.residual, fit.arc, fit.n_samples
                )
            )
        self._silent = {i for i, has_link in enumerate(linked) if not has_link}
        return events

    def _suspect_jammer(
        self, belief: LearningBelief, obs: TeamObservation, robot: int, listeners: list[int]
    ) -> list[Event]:
        """A teammate within radio range fell silent: a jammer is near where it is. Until its
        circle is fitted, the league keeps clear of a provisional comm zone there, unless one
        is known nearby."""
        provisional = self.settings.provisional_zone
        std = provisional.std
        where = obs.positions[robot]
        others = obs.positions[listeners]
        reach = self.settings.comm_range
        if not provisional.enabled or (
            reach is not None and np.min(np.linalg.norm(others - where, axis=1)) > reach
        ):
            return []
        known = belief.league_knowledge([listeners[0]]).of_kind("comm")
        if any(np.linalg.norm(z.mean - where) < 2 * std for z in known):
            return []
        zone = ZoneEstimate(
            key=f"silence{robot}@{obs.step}",
            kind="comm",
            mean=np.array(where, dtype=float),
            cov=std**2 * np.eye(2),
            size=self.settings.circle_fit.inferred_delta2,
            persistence="unknown",
            source="silence",
            learned_step=obs.step,
            zone_id=None,
        )
        for i in listeners:
            belief.learn(i, zone)
        return [Event.zone_suspected(obs.step, robot, where[0], where[1])]
