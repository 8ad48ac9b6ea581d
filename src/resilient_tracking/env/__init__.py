"""The world as learning environments (``pip install "resilient-tracking[rl]"``).

- :func:`parallel_env`: a PettingZoo ``ParallelEnv``, one agent per robot;
- :class:`~resilient_tracking.env.team.TeamEnv`: the team as one Gymnasium agent, registered as
  ``gymnasium.make("resilient_tracking/Team-v0", scenario=...)`` once this package is imported.

Both drive the world, failure process, belief and leagues of ``rtrack run``
(:class:`~resilient_tracking.env.session.TrackingSession`); agents observe what their robot
knows (:mod:`resilient_tracking.belief.agent_view`), never truth. ``docs/environment.md`` has
the details.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium

from resilient_tracking.env.options import make_session
from resilient_tracking.env.parallel import TrackingParallelEnv, agent_name
from resilient_tracking.env.reward import StepOutcome, TrackingReward
from resilient_tracking.env.session import TrackingSession
from resilient_tracking.env.team import TeamEnv
from resilient_tracking.scenario import Scenario

#: The Gymnasium id of :class:`TeamEnv`.
TEAM_ENV_ID = "resilient_tracking/Team-v0"

__all__ = [
    "TEAM_ENV_ID",
    "StepOutcome",
    "TeamEnv",
    "TrackingParallelEnv",
    "TrackingReward",
    "TrackingSession",
    "agent_name",
    "parallel_env",
]


def parallel_env(
    scenario: Scenario | str | Path = "sensing-temp",
    seed: int | None = None,
    render_mode: str | None = None,
    retire: bool = False,
    **session_options: Any,
) -> TrackingParallelEnv:
    """The PettingZoo environment of ``scenario`` (a shipped name, a file or a loaded
    scenario); ``seed`` is the first episode's when ``reset`` is given none (default: the
    scenario's); with ``retire``, an agent whose robot can neither sense nor talk for good
    leaves the episode. ``session_options``: ``steps``, ``expert``, ``max_zones``, ``reward``,
    ``record`` (see :func:`~resilient_tracking.env.options.make_session`)."""
    session = make_session(scenario, **session_options)
    first = session.scenario.seed if seed is None else seed
    return TrackingParallelEnv(session, first, render_mode, retire)


if TEAM_ENV_ID not in gymnasium.registry:
    gymnasium.register(id=TEAM_ENV_ID, entry_point="resilient_tracking.env.team:TeamEnv")
