"""Guards: the failure-aware team's mechanisms beyond the paper, one component each.

Built-ins (docs/model.md §6), in the order they register and add their rows:

- ``comm_hazard`` (on by default): keep clear of the hazard of known comm zones;
- ``exposure``: each known zone's risk level shrinks as the team's exposure to it grows;
- ``last_sensors`` (on by default): more caution as the team's sensors are lost;
- ``lure``: keep away from targets suspected of luring robots into danger;
- ``quarantine``: keep out of radio range of teammates known compromised;
- ``safe_circling`` (on by default): a circling robot turns back at a known sensing zone;
- ``signal_turns``: a robot circles its attacker a few times, then tracks alone again;
- ``ignore_temporary_jammers``: leagues plan as if known temporary jammers were not there;
- ``priced``: each zone row's risk level follows what its failure would cost.

The contract is :class:`~.base.Guard`; a new guard is one new file that registers itself
(:func:`~.base.register_guard`) or an entry point of the group ``resilient_tracking.guards``.
"""

from __future__ import annotations

from resilient_tracking.policies.guards.base import GUARDS, Guard, GuardParams, register_guard
from resilient_tracking.policies.guards.comm_hazard import CommHazardGuard
from resilient_tracking.policies.guards.exposure import ExposureGuard
from resilient_tracking.policies.guards.last_sensors import LastSensorsGuard
from resilient_tracking.policies.guards.lure import LureGuard
from resilient_tracking.policies.guards.priced import PricedCautionGuard
from resilient_tracking.policies.guards.quarantine import QuarantineGuard
from resilient_tracking.policies.guards.safe_circling import SafeCirclingGuard
from resilient_tracking.policies.guards.settings import GuardsSpec
from resilient_tracking.policies.guards.signal_turns import SignalTurnsGuard
from resilient_tracking.policies.guards.temporary_jammers import IgnoreTemporaryJammersGuard

__all__ = [
    "GUARDS",
    "CommHazardGuard",
    "ExposureGuard",
    "Guard",
    "GuardParams",
    "GuardsSpec",
    "IgnoreTemporaryJammersGuard",
    "LastSensorsGuard",
    "LureGuard",
    "PricedCautionGuard",
    "QuarantineGuard",
    "SafeCirclingGuard",
    "SignalTurnsGuard",
    "register_guard",
]
