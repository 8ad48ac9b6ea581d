"""The guard contract: one mechanism beyond the paper's Algorithm 1, added to the failure-aware
team as a component (docs/model.md §6).

A guard is a class with a pydantic ``Params`` (a subclass of :class:`GuardParams`, whose
``enabled`` is the one on/off switch) and a few hooks, each a no-op by default, so a guard
overrides only what it does:

* what it **reads**: :meth:`Guard.observe` sees each tick's observation before the leagues plan;
  :meth:`Guard.league_rows` sees a league's estimate; every hook sees belief only;
* what it **adds to the league problem**: risk levels of the keep-out rows of known zones
  (:meth:`Guard.sensing_risk`, :meth:`Guard.zone_risk`), a keep-out disc around a known comm
  zone's hazard (:meth:`Guard.guards_hazard`), whether a known comm zone's eq. 7d rows stay
  (:meth:`Guard.guards_links`), and rows of its own (:meth:`Guard.league_rows`, eq. 7c);
* what a failure **costs**: the risk levels of a league's zone rows, changed in place
  (:meth:`Guard.price_rows`, after every guard's :meth:`Guard.after_rows`);
* how a robot **circles its attacker** (Alg. 4): when it may stop (:meth:`Guard.stops_circling`)
  and when it turns back (:meth:`Guard.turns_back`);
* the **events** it emits, returned by :meth:`Guard.league_rows`.

Register a guard with :func:`register_guard` (or an entry point in the group
``resilient_tracking.guards``); a scenario configures it under ``guards.<name>``. A new guard is
one new file.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.layout import sensing_table
from resilient_tracking.registry import Registry
from resilient_tracking.spec import Strict
from resilient_tracking.team_config import TeamConfig

if TYPE_CHECKING:
    from resilient_tracking.policies.failure_aware_params import FailureAwareParams


@dataclass
class LeagueRows:
    """A league's zone rows for one tick, which :meth:`Guard.price_rows` may change in place:
    the eq. 7c table (``layout.SensingRow``; sensing zones' rows, then comm zones' keep-out
    discs) and the eq. 7d table (``layout.CommRow``), each row's zone key beside it."""

    sensing: np.ndarray
    sensing_keys: list[str]
    comm: np.ndarray
    comm_keys: list[str]


class GuardParams(Strict):
    """Parameters of a guard: ``enabled`` switches it on or off; subclasses add their own."""

    enabled: bool = Field(False, description="Whether the team uses this guard.")


class Guard:
    """One mechanism beyond the paper (module docstring). ``params`` are its validated
    ``Params``, ``config`` the team, ``method`` the failure-aware policy's parameters."""

    #: the name a scenario configures it by (``guards.<name>``)
    name: ClassVar[str] = "guard"
    Params: ClassVar[type[GuardParams]] = GuardParams

    def __init__(self, params: GuardParams, config: TeamConfig, method: FailureAwareParams):
        self.params = params
        self.config = config
        self.method = method

    def observe(self, obs: TeamObservation) -> None:
        """Once a tick, before the leagues plan."""

    def sensing_risk(self, eps: float, sensing: int, m: int) -> float:
        """The risk level of the sensing zones' eq. 7c rows, given ``eps`` so far, with
        ``sensing`` of the team's ``m`` robots still sensing."""
        return eps

    def zone_risk(self, eps: float, zone: ZoneEstimate) -> float:
        """The risk level of ``zone``'s keep-out row (eq. 7c), given ``eps`` so far."""
        return eps

    def guards_hazard(self, zone: ZoneEstimate) -> bool:
        """Whether robots keep clear of known comm zone ``zone``'s hazard with an eq. 7c disc
        of radius ``comm_clearance + w5`` at risk level ε1 (a league besides eq. 7d; a robot
        alone at ε1 instead of ε2)."""
        return False

    def guards_links(self, zone: ZoneEstimate) -> bool:
        """Whether a league keeps its links clear of known comm zone ``zone`` (eq. 7d)."""
        return True

    def rows_state(self, zones: tuple[ZoneEstimate, ...]) -> Hashable:
        """What the zone rows depend on besides the zones, ``w5``, being alone and the risk
        levels (the rows are made again when it changes)."""
        return None

    def after_rows(
        self,
        keys: list[str],
        table: np.ndarray,
        n_sensing: int,
        robots: list[int],
        obs: TeamObservation,
    ) -> None:
        """After a league's zone rows are made: the sensing table ``table`` (its first
        ``n_sensing`` rows sensing zones', the rest comm hazards'), the zone key of each row."""

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
        """Eq. 7c rows of this guard's own for the league ``robots`` (appended after the zones'
        rows ``zone_rows``), from its ``estimate`` and the estimate ``predicted`` to the planned
        step, at the margin ``beta1`` of risk level ε1; and the events of what it found."""
        return sensing_table(), []

    def price_rows(
        self,
        rows: LeagueRows,
        robots: list[int],
        estimate: TargetEstimate,
        knowledge: KnowledgeBase,
        obs: TeamObservation,
    ) -> None:
        """Change the risk levels (the ``BETA`` column) of the league ``robots``' zone ``rows``
        in place, from its ``estimate``, the zones it knows and ``obs``."""

    def stops_circling(
        self, robot: int, attacker: ZoneEstimate | None, obs: TeamObservation
    ) -> bool:
        """Whether ``robot``, whose radio a permanent comm zone destroyed, stops circling its
        ``attacker`` estimate (Alg. 4) and tracks alone; asked every tick it circles."""
        return False

    def turns_back(
        self,
        robot: int,
        obs: TeamObservation,
        step: np.ndarray,
        keep_out: Callable[[], np.ndarray],
    ) -> bool:
        """Whether ``robot``, circling its attacker, turns back instead of moving by ``step``;
        ``keep_out()`` gives the sensing zones' keep-out rows (eq. 7c, at ε1)."""
        return False


#: Every guard findable by name: the built-ins, entry points of the group
#: ``resilient_tracking.guards`` and dotted paths ``package.module:Class``.
GUARDS: Registry[type[Guard]] = Registry(
    "guard", "resilient_tracking.guards", Guard, builtins=("resilient_tracking.policies.guards",)
)

#: Class decorator registering a guard under a name: ``@register_guard("standoff")``.
register_guard = GUARDS.register
