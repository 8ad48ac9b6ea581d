"""The team as a PettingZoo ``ParallelEnv``: one agent per robot, all acting at once."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from resilient_tracking.env.checks import agents_acting, velocities
from resilient_tracking.env.options import RENDER_MODES, Seeds, check_render_mode
from resilient_tracking.env.render import map_frame
from resilient_tracking.env.session import TrackingSession
from resilient_tracking.env.spaces import velocity_space, view_space


def agent_name(robot: int) -> str:
    """The agent of robot ``robot``: ``robot_0``, ``robot_1``…"""
    return f"robot_{robot}"


class TrackingParallelEnv(ParallelEnv):
    """Every robot of a scenario's team as an agent (see ``docs/environment.md``).

    Each agent observes its robot's view (:mod:`resilient_tracking.belief.agent_view`) and
    acts with a velocity ``(2,)`` within its bound; every agent gets the team's reward. The
    episode ends for all agents at once: terminated when every sensor is out, truncated at the
    scenario's steps. With ``retire``, an agent whose robot has lost both its sensor and its
    radio for good is terminated on its own (it leaves ``agents``, and its robot holds), as
    multi-agent libraries expect of an agent that can no longer act on the outcome. ``infos``
    hold the run's numbers (:meth:`TrackingSession.metrics`).

    What it refuses, leaving the episode as it was: a step before ``reset`` or after the
    episode ended (:class:`~resilient_tracking.env.checks.ResetNeeded`), actions that do not
    name exactly the live agents (``agents``), an agent's action that is not a ``(2,)`` array
    of real numbers, a seed that is not a non-negative integer
    (:mod:`resilient_tracking.env.checks`).
    """

    metadata = {"name": "resilient_tracking_v0", "render_modes": list(RENDER_MODES)}

    def __init__(
        self,
        session: TrackingSession,
        seed: int,
        render_mode: str | None = None,
        retire: bool = False,
    ):
        check_render_mode(render_mode, session)
        if not isinstance(retire, bool):
            raise TypeError(f"retire: expected True or False, got {retire!r}")
        self.session = session
        #: whether an agent whose robot can neither sense nor talk for good leaves the episode
        self.retire = retire
        self.render_mode = render_mode
        self._seeds = Seeds(seed)
        m = session.shape.n_robots
        self.possible_agents = [agent_name(i) for i in range(m)]
        self.agents: list[str] = []
        self._view_space = view_space(session.shape)
        self._velocity_spaces = {agent_name(i): velocity_space(session.u_max[i]) for i in range(m)}

    def observation_space(self, agent: str) -> spaces.Dict:
        """The space of a robot's view (the same for every agent)."""
        return self._view_space

    def action_space(self, agent: str) -> spaces.Box:
        """Velocities within the agent's robot's bound, ``(2,)``."""
        return self._velocity_spaces[agent]

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, Any]]]:
        """A new episode (at ``seed``, else the next seed); every agent's view and the run's
        numbers."""
        chosen = self._seeds.choose(seed)
        self.session.reset(chosen)
        self._seeds.started(chosen)
        self.agents = list(self.possible_agents)
        return self._observations(), self._infos()

    def step(
        self, actions: dict[str, np.ndarray]
    ) -> tuple[
        dict[str, dict[str, np.ndarray]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """Every robot moves with its agent's action (every live agent acts; a retired
        agent's robot holds, and an action given for it is ignored, as TorchRL gives one for
        every agent); views, the team's reward, terminations, truncations and the run's
        numbers, for each agent live before the step."""
        self.session.check_steppable()
        gone = [agent for agent in self.possible_agents if agent not in self.agents]
        agents_acting(actions, self.agents, gone if self.retire else ())
        controls = np.stack(
            [
                velocities(f"action of {agent}", actions[agent], self._velocity_spaces[agent])
                if agent in self.agents
                else np.zeros(2)
                for agent in self.possible_agents
            ]
        )
        reward, terminated, truncated = self.session.step(controls)
        agents = self.agents
        observations, infos = self._observations(agents), self._infos(agents)
        rewards = dict.fromkeys(agents, reward)
        retired = self._retired(observations)
        terminations = {agent: terminated or agent in retired for agent in agents}
        truncations = dict.fromkeys(agents, truncated and not terminated)
        if terminated or truncated:
            self.agents = []
        else:
            self.agents = [agent for agent in agents if agent not in retired]
        return observations, rewards, terminations, truncations, infos

    def expert_actions(self) -> dict[str, np.ndarray]:
        """The expert policy's action for every agent at the current step (stepping with them
        reproduces ``rtrack run`` with that policy)."""
        controls = self.session.expert_controls()
        return {agent: controls[i] for i, agent in enumerate(self.possible_agents)}

    def render(self) -> np.ndarray | None:
        """The map of the run so far (``rgb_array``), or ``None`` without a render mode."""
        if self.render_mode is None:
            return None
        return map_frame(self.session.result())

    def close(self) -> None:
        """Nothing to release."""
        pass

    def _retired(self, observations: dict[str, dict[str, np.ndarray]]) -> set[str]:
        """The agents whose robot has lost its sensor and its radio for good (with
        ``retire``; the view's ``own`` flags 5 and 6)."""
        if not self.retire:
            return set()
        return {agent for agent, view in observations.items() if view["own"][5:7].all()}

    def _observations(self, agents: list[str] | None = None) -> dict[str, dict[str, np.ndarray]]:
        views = self.session.views()
        return {
            agent: {name: rows[i] for name, rows in views.items()}
            for i, agent in enumerate(self.possible_agents)
            if agents is None or agent in agents
        }

    def _infos(self, agents: list[str] | None = None) -> dict[str, dict[str, Any]]:
        metrics = self.session.metrics()
        return {
            agent: dict(metrics)
            for agent in self.possible_agents
            if agents is None or agent in agents
        }
