"""Checking a policy's decision before any robot moves: its type and shape, finite controls
within each robot's velocity bounds, one mode per robot, events the events table can hold and
plans the team table can count — every field of a :class:`Decision` as a run uses it.

The team (:meth:`~resilient_tracking.team.Team.step`) turns every problem into an event and
the safe action for the robots concerned; :func:`~resilient_tracking.policy_check.check_policy`
reports them.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, fields

import numpy as np

from resilient_tracking.events import EVENT_NAMES, TRUTH_EVENTS, Event
from resilient_tracking.models.numpy_twins import all_within
from resilient_tracking.planning.plan_result import PlanResult
from resilient_tracking.policies.base import Decision
from resilient_tracking.team_config import TeamConfig

#: How far (m/s) a control may pass its bound before it is a violation; below it the robot's
#: own saturation clips it (a solver meets box bounds only to its tolerance).
BOUND_TOLERANCE = 1e-6


@dataclass(frozen=True)
class DecisionProblem:
    """One thing wrong with a decision: for one robot, or (``robot is None``) the whole of it."""

    robot: int | None
    #: ``type``, ``shape``, ``not_finite``, ``out_of_bounds``, ``modes``, ``events`` or ``plans``
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
    for kind, why in (
        ("events", events_problem(decision.events)),
        ("plans", plans_problem(decision.plans)),
    ):
        if why is not None:
            problems.append(DecisionProblem(None, kind, why))
    return controls, problems


#: Fields of :class:`Event` stored as integers (the others are text).
_INT_FIELDS = ("step", "robot", "zone")


def _is_int(value: object) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def _is_number(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def events_problem(events: object) -> str | None:
    """Why ``Decision.events`` cannot be recorded (a list of :class:`Event`, each field of the
    type of its column in the events table, a name of a team-side event), else ``None``."""
    if not isinstance(events, list | tuple):
        return f"events must be a list of Event, got {type(events).__name__}"
    for k, e in enumerate(events):
        if not isinstance(e, Event):
            return f"events[{k}] is {type(e).__name__} {e!r:.60}, not an Event"
        for f in fields(Event):
            value, integer = getattr(e, f.name), f.name in _INT_FIELDS
            if not (_is_int(value) if integer else isinstance(value, str)):
                wanted = "an integer" if integer else "text"
                return f"events[{k}].{f.name} must be {wanted}, got {value!r:.60}"
        if e.event not in EVENT_NAMES or e.event in TRUTH_EVENTS:
            return f"events[{k}].event {e.event!r:.60} is not the name of a team's event"
    return None


def plans_problem(plans: object) -> str | None:
    """Why ``Decision.plans`` cannot be counted (a list of :class:`PlanResult` whose
    ``success`` is a bool, ``iterations`` an integer and ``solve_ms`` a number), else ``None``."""
    if not isinstance(plans, list | tuple):
        return f"plans must be a list of PlanResult, got {type(plans).__name__}"
    for k, plan in enumerate(plans):
        if not isinstance(plan, PlanResult):
            return f"plans[{k}] is {type(plan).__name__} {plan!r:.60}, not a PlanResult"
        for name, wanted, ok in (
            ("success", "a bool", isinstance(plan.success, bool | np.bool_)),
            ("iterations", "an integer", _is_int(plan.iterations)),
            ("solve_ms", "a number", _is_number(plan.solve_ms)),
        ):
            if not ok:
                return f"plans[{k}].{name} must be {wanted}, got {getattr(plan, name)!r:.60}"
    return None


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
