"""The reward of a step, from what the step did to the team (its trace, its attacks)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class StepOutcome:
    """What one environment step did, for a reward to weigh."""

    #: the position trace of the team's estimate before and after the step
    trace_before: float
    trace_after: float
    #: attacks felt in the step (each robot hit counts once)
    attacks: int
    #: robots whose sensor works after the step
    sensing: int


@dataclass(frozen=True)
class TrackingReward:
    """The default reward: ``trace_weight`` times the decrease of the team's trace, minus
    ``attack_penalty`` per attack. Any callable from :class:`StepOutcome` to a number can
    replace it."""

    trace_weight: float = 1.0
    attack_penalty: float = 10.0

    def __call__(self, outcome: StepOutcome) -> float:
        decrease = outcome.trace_before - outcome.trace_after
        return self.trace_weight * decrease - self.attack_penalty * outcome.attacks
