"""What both environments are built from: a scenario (name, file or object) and their options."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from resilient_tracking import scenarios
from resilient_tracking.belief.agent_view import MAX_ZONES
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
) -> TrackingSession:
    """A session of ``scenario`` (a shipped name, a file or a loaded scenario), ``steps``
    replacing the scenario's number of steps when given."""
    loaded = scenario if isinstance(scenario, Scenario) else scenarios.load(scenario)
    if steps is not None:
        loaded = loaded.with_overrides(steps=steps)
    return TrackingSession(loaded, expert=expert, max_zones=max_zones, reward=reward)


class Seeds:
    """The seed of each episode: the one given to ``reset``, else the next after the last
    (starting from the environment's own seed), so that episodes differ and repeat."""

    def __init__(self, first: int):
        self.next = first

    def take(self, given: int | None) -> int:
        """The seed of the episode being reset."""
        seed = self.next if given is None else int(given)
        self.next = seed + 1
        return seed
