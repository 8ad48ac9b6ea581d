"""What both environments are built from: a scenario (name, file or object) and their options."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from resilient_tracking import builtin_scenarios
from resilient_tracking.belief.agent_view import MAX_ZONES
from resilient_tracking.env.checks import integer, seed_value
from resilient_tracking.env.reward import StepOutcome
from resilient_tracking.env.session import TrackingSession
from resilient_tracking.scenario import Scenario

#: Render modes of both environments.
RENDER_MODES = ("rgb_array",)


def make_session(
    scenario: Scenario | str | Path,
    steps: int | None = None,
    expert: str = "failure_aware",
    max_zones: int = MAX_ZONES,
    reward: Callable[[StepOutcome], float] | None = None,
    record: bool = True,
    team: str | None = None,
) -> TrackingSession:
    """A session of ``scenario`` (a shipped name, a file or a loaded scenario), ``steps``
    replacing the scenario's number of steps when given, run by the named ``team`` when given
    (its belief, and the expert's policy settings; ``rtrack teams`` lists them);
    ``record=False`` keeps no run tables (faster; the session then has no ``result`` and the
    environment does not render). An argument of the wrong kind is refused (``TypeError`` or
    ``ValueError`` naming it) before anything is loaded."""
    check_session_options(scenario, steps, expert, max_zones, reward, record, team)
    loaded = scenario if isinstance(scenario, Scenario) else builtin_scenarios.load(scenario)
    if team is not None:
        loaded = loaded.with_team(team)
    if steps is not None:
        loaded = loaded.with_overrides(steps=steps)
    return TrackingSession(loaded, expert=expert, max_zones=max_zones, reward=reward, record=record)


def check_session_options(
    scenario: Any,
    steps: Any,
    expert: Any,
    max_zones: Any,
    reward: Any,
    record: Any,
    team: Any,
) -> None:
    """Refuse arguments of :func:`make_session` of the wrong kind, naming the first."""
    if not isinstance(scenario, Scenario | str | Path):
        raise TypeError(
            "scenario: expected a shipped name, a file path or a Scenario, "
            f"got {type(scenario).__name__}"
        )
    if steps is not None:
        integer("steps", steps, 1)
    integer("max_zones", max_zones, 0)
    for name, value in (("expert", expert), ("team", team)):
        if not isinstance(value, str) and not (name == "team" and value is None):
            raise TypeError(f"{name}: expected a name (str), got {type(value).__name__}")
    if reward is not None and not callable(reward):
        raise TypeError(
            f"reward: expected a callable of a StepOutcome, got {type(reward).__name__}"
        )
    if not isinstance(record, bool):
        raise TypeError(f"record: expected True or False, got {record!r}")


def check_render_mode(render_mode: str | None, session: TrackingSession) -> None:
    """Refuse a render mode the environments do not have, or one without run tables to draw."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode: expected one of {RENDER_MODES}, got {render_mode!r}")
    if render_mode is not None and not session.record:
        raise ValueError("render_mode: rendering draws the run tables, which record=False drops")


class Seeds:
    """The seed of each episode: the one given to ``reset``, else the next after the last
    (starting from the environment's own seed), so that episodes differ and repeat. Seeds are
    non-negative integers; anything else is refused naming ``seed``."""

    def __init__(self, first: int):
        self.next: int = integer("seed", first, 0)

    def choose(self, given: int | None) -> int:
        """The seed of the episode to reset (nothing changes: a refused seed, or a reset that
        fails, leaves the next seed as it was)."""
        chosen = seed_value("seed", given)
        return self.next if chosen is None else chosen

    def started(self, seed: int) -> None:
        """The episode at ``seed`` has begun: the next reset without a seed takes the next."""
        self.next = seed + 1
