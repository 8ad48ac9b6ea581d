"""Keeping clear of the hazard of known comm zones (beyond the paper, docs/model.md §6).

Eq. 7d keeps a league's *links* clear of a jammer, but a comm zone's hazard (its attack,
docs/model.md §1.1) can destroy a robot's radio whatever the links. With this guard, a league
keeps every robot clear of each known comm zone not known to be temporary with an eq. 7c disc
of radius ``comm_clearance + w5`` (plus any observed clearance) at the sensing zones' risk level
ε1, besides eq. 7d; a robot alone keeps clear of it at ε1 instead of ε2. A temporary zone costs
an outage, which eq. 7d and the cool-down already weigh.
"""

from __future__ import annotations

from pydantic import Field

from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.policies.guards.base import Guard, GuardParams, register_guard


class CommHazardParams(GuardParams):
    """Keep clear of the hazard of known comm zones not known to be temporary."""

    enabled: bool = Field(True, description="Whether the team uses this guard (on by default).")


@register_guard("comm_hazard")
class CommHazardGuard(Guard):
    """An eq. 7c disc around each known comm zone not known to be temporary (module docstring)."""

    name = "comm_hazard"
    Params = CommHazardParams

    def guards_hazard(self, zone: ZoneEstimate) -> bool:
        """A comm zone not known to be temporary."""
        return zone.persistence != "temporary"
