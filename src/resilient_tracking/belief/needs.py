"""What a policy needs of the team's belief, declared by the policy and honoured by the belief.

The belief always keeps the leagues and one target estimate per league. Beyond that a policy
may ask for zone knowledge (attack clues learned and shared within leagues; a vanilla team
keeps none), for comm zones inferred from silent teammates (the paper's Alg. 3), for zone
estimates that age and move (:mod:`~resilient_tracking.belief.zone_motion`) and for a watch
on silently degraded sensors.
"""

from __future__ import annotations

from dataclasses import dataclass

from resilient_tracking.belief.degradation_watch import DegradationWatchSettings
from resilient_tracking.belief.silent_robots import SilentRobotSettings
from resilient_tracking.belief.zone_motion import ZoneMotionSettings


@dataclass(frozen=True)
class BeliefNeeds:
    """The belief a policy decides from (module docstring)."""

    #: learn zones from attack clues and share them within each league
    zones: bool = True
    #: infer comm zones from silent teammates with these settings (``None``: do not)
    silent_robots: SilentRobotSettings | None = None
    #: track identified zones' motion from successive clues with these settings (``None``:
    #: zone estimates stay where they were learned)
    zone_motion: ZoneMotionSettings | None = None
    #: find silently degraded sensors and adapt their noise with these settings (``None``:
    #: do not; docs/model.md §6.4)
    degradation: DegradationWatchSettings | None = None
