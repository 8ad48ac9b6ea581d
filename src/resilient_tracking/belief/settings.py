"""The belief's own settings: the ``belief`` section of a scenario (docs/scenario-format.md).

How the team reads silent teammates (the paper's Alg. 3, with the provisional zone where one
falls silent), and the belief's features beyond the paper: zone estimates that move
(:mod:`~.zone_motion`) and the watch on silently degraded sensors (:mod:`~.degradation_watch`).
Each optional feature is a section with ``enabled`` and its settings. The policy declares what
it needs of the belief (:class:`~.needs.BeliefNeeds`); these settings say how.
"""

from __future__ import annotations

from pydantic import Field

from resilient_tracking.belief.circle_fit import CircleFitSettings
from resilient_tracking.belief.degradation_watch import DegradationWatchSettings
from resilient_tracking.belief.silent_robots import ProvisionalZoneSettings
from resilient_tracking.belief.zone_motion import ZoneMotionSettings
from resilient_tracking.spec import Strict


class BeliefSettings(Strict):
    """The team's belief: how it reads silent teammates, and its features beyond the paper."""

    circle_fit: CircleFitSettings = Field(
        CircleFitSettings(),
        description="When a silent robot's observed path counts as a circle (Alg. 3).",
    )
    provisional_zone: ProvisionalZoneSettings = Field(
        ProvisionalZoneSettings(),
        description=(
            "A provisional comm zone where a teammate within radio range falls silent, until a"
            " circle fit replaces it."
        ),
    )
    zone_motion: ZoneMotionSettings = Field(
        ZoneMotionSettings(),
        description=(
            "Beyond the paper: zone estimates that move with a velocity estimated from"
            " successive clues and grow uncertain with time since the last one"
            " (docs/model.md §6.3)."
        ),
    )
    degradation_watch: DegradationWatchSettings = Field(
        DegradationWatchSettings(),
        description=(
            "Beyond the paper: find silently degraded sensors and adapt to them"
            " (docs/model.md §6.4)."
        ),
    )
