"""One episode seen as a learning environment: reset, step with every robot's velocity, read
each robot's view; shared by the multi-agent and the team environments.

It drives the same :class:`~resilient_tracking.sim.episode.EpisodeStepper` as ``rtrack run``:
the world, its failure process, the team's belief and leagues, the run tables. The team is built
with an *expert* policy (``failure_aware`` by default) whose belief needs set what the belief
keeps and whose decisions :meth:`TrackingSession.expert_controls` offers; a step whose controls
are exactly the expert's is recorded as the expert's decision, so an episode driven by the
expert has ``rtrack run``'s tables bit for bit.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from resilient_tracking.belief.agent_view import MAX_ZONES, ViewShape, team_views
from resilient_tracking.env.checks import ResetNeeded
from resilient_tracking.env.reward import StepOutcome, TrackingReward
from resilient_tracking.models.numpy_twins import all_finite
from resilient_tracking.policies.base import Decision
from resilient_tracking.runs.records import EpisodeResult
from resilient_tracking.scenario import Scenario
from resilient_tracking.sim.episode import EpisodeStepper

log = logging.getLogger(__name__)

#: The mode recorded for robots moved by the environment's actions.
AGENT_MODE = "agent"


class TrackingSession:
    """An episode of ``scenario`` stepped by an outside controller (module docstring)."""

    def __init__(
        self,
        scenario: Scenario,
        expert: str = "failure_aware",
        max_zones: int = MAX_ZONES,
        reward: Callable[[StepOutcome], float] | None = None,
        record: bool = True,
    ):
        self.scenario = scenario
        #: whether episodes record the run tables (``False``: faster; no ``result``, no render)
        self.record = record
        self.expert = expert
        self.reward = reward or TrackingReward()
        self.shape = ViewShape(len(scenario.robots), len(scenario.targets), max_zones)
        self.u_max = np.array([r.u_max for r in scenario.robots], dtype=float)
        self.stepper: EpisodeStepper | None = None
        self._expert_decision: Decision | None = None
        #: whether the episode has ended (terminated or truncated): it takes no more steps
        self.ended = False
        self.attacks = 0
        #: the position trace of the team's estimate at the sensed step
        self.trace = float("nan")

    # ------------------------------------------------------------------ episode

    def reset(self, seed: int) -> None:
        """A new episode at ``seed``: the world at step 0, sensed by the team."""
        self.stepper = EpisodeStepper(self.scenario, self.expert, seed, record=self.record)
        self._expert_decision = None
        self.ended = False
        self.attacks = 0
        obs = self.stepper.sense()
        self.attacks += len(obs.attacks)
        self.trace = self._team_trace()

    @property
    def running(self) -> EpisodeStepper:
        """The episode's stepper (``reset`` first)."""
        if self.stepper is None:
            raise ResetNeeded("no episode yet: call reset() first")
        return self.stepper

    def check_steppable(self) -> None:
        """Refuse a step with no episode running (before the first reset, after the end)."""
        if self.stepper is None:
            raise ResetNeeded("no episode yet: call reset() before step()")
        if self.ended:
            raise ResetNeeded(
                f"the episode has ended (terminated or truncated at step "
                f"{self.stepper.steps_done}): call reset() before stepping again"
            )

    def expert_controls(self) -> np.ndarray:
        """The expert policy's ``(M, 2)`` commands for the current step (decided once)."""
        stepper = self.running
        if self._expert_decision is None:
            assert stepper.obs is not None
            self._expert_decision = stepper.team.policy.act(stepper.team.belief, stepper.obs)
        return np.asarray(self._expert_decision.controls, dtype=float)

    def step(self, controls: np.ndarray) -> tuple[float, bool, bool]:
        """Move every robot with ``controls`` ``(M, 2)`` (clipped to its bounds and the
        workspace), advance the world and sense the next step; returns the reward, whether
        every robot is blind (terminated) and whether the scenario's steps are done
        (truncated). Refused, with nothing changed, once the episode has ended or when
        ``controls`` is not ``(M, 2)``."""
        self.check_steppable()
        stepper = self.running
        obs = stepper.obs
        assert obs is not None
        controls = np.asarray(controls, dtype=float)
        if controls.shape != obs.positions.shape:
            raise ValueError(
                f"controls: expected shape {obs.positions.shape}, one row per robot, "
                f"got {controls.shape}"
            )
        controls = stepper.team.config.clip(controls, obs.positions)
        trace_before = self.trace
        decision, valid = self._expert_decision, False
        if decision is None or not np.array_equal(controls, decision.controls):
            decision = Decision(controls, [AGENT_MODE] * len(controls))
            # clipped to the team's bounds, so valid if finite (else the team's check holds
            # the robots concerned, as any invalid decision)
            valid = all_finite(controls)
        stepper.act(decision, valid)
        self._expert_decision = None
        after = stepper.sense()
        self.attacks += len(after.attacks)
        self.trace = self._team_trace()
        outcome = StepOutcome(
            trace_before=trace_before,
            trace_after=self.trace,
            attacks=len(after.attacks),
            sensing=after.sensing_ok.tolist().count(True),
        )
        terminated = outcome.sensing == 0
        truncated = stepper.steps_done >= self.scenario.steps
        self.ended = terminated or truncated
        return float(self.reward(outcome)), terminated, truncated

    # ------------------------------------------------------------------ reading

    def _team_trace(self) -> float:
        """The position trace of the team's estimate now."""
        return float(self.running.team.belief.team_estimate().position_trace())

    def views(self) -> dict[str, np.ndarray]:
        """Every robot's view of the current step, each field with a leading axis of the
        robots (:func:`~resilient_tracking.belief.agent_view.team_views`)."""
        stepper = self.running
        assert stepper.obs is not None
        belief, obs = stepper.team.belief, stepper.obs
        return team_views(belief, obs, self.u_max, self.shape.max_zones)

    def metrics(self) -> dict[str, Any]:
        """The run's numbers now, for ``info``: step, time, the team's trace, the MSE of its
        estimate (against truth: a score, never an input to a policy), attacks so far, failed
        sensors and radios, leagues."""
        stepper = self.running
        obs = stepper.obs
        assert obs is not None
        return {
            "step": int(obs.step),
            "time": float(obs.time),
            "trace": self.trace,
            "mse": stepper.last_mse,
            "attacks": self.attacks,
            "n_sensing_failed": obs.sensing_ok.tolist().count(False),
            "n_comm_failed": obs.comm_ok.tolist().count(False),
            "n_leagues": len(stepper.team.belief.leagues),
        }

    def result(self) -> EpisodeResult:
        """The run tables of the steps taken so far (those of ``rtrack run``)."""
        return self.running.result()
