"""Letting known temporary jammers be (beyond the paper; docs/generalization.md measures it).

The paper keeps a league's links clear of every known comm zone (eq. 7d). A zone known to be
temporary costs only a short outage, so with this guard a league plans as if it were not there:
no eq. 7d rows for it. A robot alone still keeps clear of it.
"""

from __future__ import annotations

from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.policies.guards.base import Guard, GuardParams, register_guard


@register_guard("ignore_temporary_jammers")
class IgnoreTemporaryJammersGuard(Guard):
    """No eq. 7d rows for comm zones known to be temporary (module docstring)."""

    name = "ignore_temporary_jammers"
    Params = GuardParams

    def guards_links(self, zone: ZoneEstimate) -> bool:
        """Not for a comm zone known to be temporary."""
        return zone.persistence != "temporary"
