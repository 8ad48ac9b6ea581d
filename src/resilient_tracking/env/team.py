"""The whole team as one Gymnasium agent (for single-agent libraries): every robot's view
stacked, every robot's velocity in one action."""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np

from resilient_tracking.env.checks import velocities
from resilient_tracking.env.options import RENDER_MODES, Seeds, check_render_mode, make_session
from resilient_tracking.env.render import map_frame
from resilient_tracking.env.spaces import velocity_space, view_space


class TeamEnv(gymnasium.Env[dict[str, np.ndarray], np.ndarray]):
    """A scenario's team as one agent (see ``docs/environment.md``).

    Observation: each field of a robot's view with a leading axis of the ``M`` robots; action:
    ``(M, 2)`` velocities within the robots' bounds; reward: the team's; terminated when every
    sensor is out, truncated at the scenario's steps; ``info``: the run's numbers. Keyword
    arguments are those of :func:`resilient_tracking.env.options.make_session`, and ``seed``,
    the first episode's seed when ``reset`` is given none (default: the scenario's).

    What it refuses, leaving the episode as it was: a step before ``reset`` or after the
    episode ended (:class:`~resilient_tracking.env.checks.ResetNeeded`), an action that is not
    an ``(M, 2)`` array of real numbers, a seed that is not a non-negative integer
    (:mod:`resilient_tracking.env.checks`).
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 10}

    def __init__(
        self,
        scenario: Any = "sensing-temp",
        seed: int | None = None,
        render_mode: str | None = None,
        **session_options: Any,
    ):
        self.session = make_session(scenario, **session_options)
        check_render_mode(render_mode, self.session)
        self.render_mode = render_mode
        self._seeds = Seeds(self.session.scenario.seed if seed is None else seed)
        self.observation_space = view_space(  # type: ignore[assignment]
            self.session.shape, self.session.shape.n_robots
        )
        self.action_space = velocity_space(self.session.u_max)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """A new episode (at ``seed``, else the next seed): the team's view, the run's
        numbers."""
        chosen = self._seeds.choose(seed)
        super().reset(seed=None if seed is None else chosen)
        self.session.reset(chosen)
        self._seeds.started(chosen)
        return self.session.views(), self.session.metrics()

    def step(
        self, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Every robot moves with its row of ``action``; the team's view, reward,
        terminated, truncated and the run's numbers."""
        self.session.check_steppable()
        controls = velocities("action", action, self.action_space)
        reward, terminated, truncated = self.session.step(controls)
        return self.session.views(), reward, terminated, truncated, self.session.metrics()

    def expert_action(self) -> np.ndarray:
        """The expert policy's ``(M, 2)`` action at the current step."""
        return self.session.expert_controls()

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """The map of the run so far (``rgb_array``), or ``None`` without a render mode."""
        if self.render_mode is None:
            return None
        return map_frame(self.session.result())
