"""What one league plan returns: controls and how the solver ladder got them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: The status of a robot left unplanned because its sub-team's plan ran out of time.
OVER_BUDGET = "over the planning budget"


@dataclass(frozen=True)
class PlanResult:
    controls: np.ndarray  # (n, 2)
    status: str
    success: bool
    #: solver iterations, summed over every attempt of this solve
    iterations: int
    solve_ms: float
    #: "" when the first attempt succeeded, else which rung was used: "warm", "cold" or "safe"
    fallback: str = ""
    #: the rung that produced the controls: "sqp", "warm", "cold" or "safe"
    rung: str = ""
    #: (rung, return status) of every attempt, in order
    attempts: tuple[tuple[str, str], ...] = field(default_factory=tuple)
    #: robots left unplanned this step because planning ran out of its time (sub-teams running
    #: free on robots; they keep their last velocity or hold,
    #: :mod:`~resilient_tracking.planning.subteams`)
    held: tuple[int, ...] = ()
    #: robots of a sub-team whose solve failed, with the safe action each took (``"escape"``
    #: or ``"hold"``); the league's other robots keep their planned controls
    #: (:mod:`~resilient_tracking.planning.subteams`)
    safe: tuple[tuple[int, str], ...] = ()
