"""What a policy needs of the team's belief, declared by the policy and honoured by the belief.

The belief always keeps the leagues and one target estimate per league. Beyond that a policy
may ask for zone knowledge (attack clues learned and shared within leagues; a vanilla team
keeps none) and for comm zones inferred from silent teammates (the paper's Alg. 3), saying how
its own robots circle. How the belief does all this, and its features beyond the paper, are the
belief's own settings (:class:`~resilient_tracking.belief.settings.BeliefSettings`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class CircleReading:
    """How the policy's robots circle their attacker (Alg. 4), so that listeners can read a
    fitted circle back into a comm zone (Alg. 3)."""

    #: chance-constraint margin β2 of the evasion circle (eq. 7d at risk level ε2)
    beta2: float
    #: margin the evading robot adds to its circle radius
    circle_margin: float


@dataclass(frozen=True)
class BeliefNeeds:
    """The belief a policy decides from (module docstring)."""

    #: learn zones from attack clues and share them within each league
    zones: bool = True
    #: infer comm zones from silent teammates, whose circles read this way (``None``: do not)
    silent_robots: CircleReading | None = None
