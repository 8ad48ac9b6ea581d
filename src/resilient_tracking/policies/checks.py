"""Checking a policy's decision before any robot moves: its type and shape, finite controls
within each robot's velocity bounds, one mode per robot.

The team (:meth:`~resilient_tracking.team.Team.step`) turns every problem into an event and
the safe action for the robots concerned; :func:`~resilient_tracking.policy_check.check_policy`
reports them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resilient_tracking.models.numpy_twins import all_within
from resilient_tracking.policies.base import Decision
from resilient_tracking.team_config import TeamConfig

#: How far (m/s) a control may pass its bound before it is a violation; below it the robot's
#: own saturation clips it (a solver meets box bounds only to its tolerance).
BOUND_TOLERANCE = 1e-6


@dataclass(frozen=True)
class DecisionProblem:
    """One thing wrong with a decision: for one robot, or (``robot is None``) the whole of it."""

    robot: int | None
    #: ``type``, ``shape``, ``not_finite``, ``out_of_bounds`` or ``modes``
    kind: str
    message: str


def decision_problems(
    decision: object, config: TeamConfig, positions: np.ndarray
) -> tuple[np.ndarray | None, list[DecisionProblem]]:
    """The decision's controls as an ``(M, 2)`` array (``None`` if it has none of that shape)
    and every problem found, robot by robot."""
    m = len(positions)
    if not isinstance(decision, Decision):
        return None, [DecisionProblem(None, "type", f"act returned {type(decision).__name__}")]
    problems: list[DecisionProblem] = []
    try:
        controls: np.ndarray | None = np.asarray(decision.controls, dtype=float)
    except (TypeError, ValueError) as err:
        controls = None
        problems.append(
            DecisionProblem(None, "type", f"controls are not an array of numbers ({err})")
        )
    if controls is not None and controls.shape != (m, 2):
        problems.append(
            DecisionProblem(
                None, "shape", f"controls have shape {controls.shape}, expected ({m}, 2)"
            )
        )
        controls = None
    if controls is not None:
        lower, upper = config.velocity_bounds(list(range(m)), positions)
        # the usual decision passes in one test: a control within its (finite) bounds is finite
        if not all_within(controls, lower, upper, BOUND_TOLERANCE):
            problems += _control_problems(controls, lower, upper)
    modes = decision.modes
    if not (isinstance(modes, list | tuple) and len(modes) == m):
        problems.append(
            DecisionProblem(None, "modes", f"modes must be one per robot ({m}), got {modes!r:.80}")
        )
    elif not all(isinstance(x, str) for x in modes):
        problems.append(DecisionProblem(None, "modes", "modes must be strings"))
    return controls, problems


def _control_problems(
    controls: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> list[DecisionProblem]:
    """A problem for each robot whose control is not finite or outside its bounds."""
    problems = []
    finite = np.isfinite(controls).all(axis=1)
    with np.errstate(invalid="ignore"):
        outside = (controls < lower - BOUND_TOLERANCE) | (controls > upper + BOUND_TOLERANCE)
    for i in np.flatnonzero(~finite | outside.any(axis=1)):
        if not finite[i]:
            kind, what = "not_finite", "not finite"
        else:
            bounds = f"[{lower[i].tolist()}, {upper[i].tolist()}]"
            kind, what = "out_of_bounds", f"outside its velocity bounds {bounds}"
        problems.append(DecisionProblem(int(i), kind, f"control {controls[i].tolist()} {what}"))
    return problems
