"""A closed-loop league workload: robots track targets across a field of known danger zones.

The planner is driven step by step: each step's :class:`ProblemInputs` come from the previous
step's controls (``x⁺ = x + u dt``), the targets move along lanes that cross the zones, and the
targets' position information evolves as in an information filter (predict: add process noise;
update: add ``Hᵀ R⁻¹ H`` of each sensing robot at its new position). The zones sit on the lanes,
so the chance constraints bind while the team tracks targets through them.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np

from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.planning.adaptation import chance_margin
from resilient_tracking.planning.layout import (
    ProblemInputs,
    Structure,
    comm_row,
    comm_table,
    sensing_row,
    sensing_table,
)
from resilient_tracking.planning.safe_action import constraint_margins

DT = 0.1
U_MAX = 1.0
SENSOR_MODEL = RangeBearingSensor(15.0, 0.2, 15.0, 0.2)
SENSOR = SENSOR_MODEL.parameters
#: failure-aware defaults (scenario.FailureAwareParams): risky and cool-down weights
RISKY = np.array([50.0, 0.05, 200.0, 100.0])
COOLDOWN = np.array([40.0, 0.05, 4000.0, 1000.0])
COOLDOWN_CLEARANCE = 0.6
BETA1 = chance_margin(0.02)
BETA2 = chance_margin(0.15)
LANE = 0.8  # m between target lanes
TARGET_SPEED = 0.2  # m/s
PROCESS_VAR = 0.01  # m² of position variance added per step


@dataclass(frozen=True)
class LeagueCase:
    """A league size with its known zones."""

    n_robots: int
    n_targets: int
    n_sensing: int
    n_comm: int

    @property
    def label(self) -> str:
        return f"{self.n_robots}x{self.n_targets}"

    @property
    def structure(self) -> Structure:
        return Structure(self.n_robots, self.n_targets, self.n_sensing, self.n_comm)


CASES = (
    LeagueCase(3, 3, 1, 1),
    LeagueCase(5, 5, 2, 1),
    LeagueCase(10, 10, 3, 2),
    LeagueCase(20, 20, 4, 2),
)


def _lanes(n: int) -> np.ndarray:
    return (np.arange(n) - (n - 1) / 2) * LANE


def measurement_information(robots: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """``Hᵀ R⁻¹ H`` (n, N, 2, 2) of each robot for each target, as in the planner's model."""
    e = SENSOR_MODEL.information(robots[:, None, :], targets[None, :, :])
    return np.stack([e[..., 0:2], e[..., 1:3]], axis=-2)


class LeagueLoop:
    """Generates the inputs of consecutive league solves and applies the controls."""

    def __init__(self, case: LeagueCase, seed: int = 0):
        self.case = case
        rng = np.random.default_rng(seed)
        n, big_n = case.n_robots, case.n_targets
        self.target_y = _lanes(big_n)
        self.target_x0 = -2.0 + 0.3 * rng.standard_normal(big_n)
        self.phase = rng.uniform(0, 2 * np.pi, big_n)
        span = max(self.target_y.max() - self.target_y.min(), LANE)
        self.lower = np.array([-4.0, self.target_y.min() - 2.0])
        self.upper = np.array([4.0, self.target_y.max() + 2.0])
        self.positions = np.column_stack([np.full(n, -2.6), np.linspace(-span / 2, span / 2, n)])
        self.positions += 0.05 * rng.standard_normal((n, 2))
        self.info = np.repeat(np.eye(2)[None] * 4.0, big_n, axis=0)
        # zones on the lanes, in the middle of the targets' path
        ys = self.target_y[np.linspace(0, big_n - 1, case.n_sensing + case.n_comm).astype(int)]
        xs = np.linspace(-0.6, 0.6, case.n_sensing + case.n_comm)
        self.zone_centres = np.column_stack([xs, ys + 0.1 * rng.standard_normal(len(ys))])
        # δ2 scaled so that the team's spread does not swamp the jamming margin
        self.delta2 = min(0.3, 0.6 / span)
        self.step_index = 0

    def targets(self, k: int) -> np.ndarray:
        t = k * DT
        x = self.target_x0 + TARGET_SPEED * t
        y = self.target_y + 0.25 * np.sin(0.3 * t + self.phase)
        return np.column_stack([x, y])

    def sensing(self, k: int) -> np.ndarray:
        """Robot 0 loses its sensor for a while mid-run (its tracking term drops out)."""
        s = np.ones(self.case.n_robots)
        if 80 <= k < 120:
            s[0] = 0.0
        return s

    def inputs(self) -> ProblemInputs:
        k = self.step_index
        cooling = 100 <= k < 110  # a cool-down window: weights and clearances jump
        weights = COOLDOWN if cooling else RISKY
        clearance = COOLDOWN_CLEARANCE if cooling else 0.0
        c = self.case
        sensing_rows = [
            sensing_row(self.zone_centres[i], 0.2 * np.eye(2), 0.4 + clearance, BETA1)
            for i in range(c.n_sensing)
        ]
        comm_rows = [
            comm_row(self.zone_centres[c.n_sensing + i], 0.15 * np.eye(2), self.delta2, BETA2, 0.0)
            for i in range(c.n_comm)
        ]
        x = self.positions
        lower = np.minimum(np.maximum(-U_MAX, (self.lower - x) / DT), 0.0)
        upper = np.maximum(np.minimum(U_MAX, (self.upper - x) / DT), 0.0)
        prior = np.linalg.inv(np.linalg.inv(self.info) + PROCESS_VAR * np.eye(2))
        return ProblemInputs(
            positions=x.copy(),
            sensing=self.sensing(k),
            targets=self.targets(k + 1),
            prior_info=prior,
            weights=weights.copy(),
            sensor=SENSOR.copy(),
            dt=DT,
            u_lower=lower,
            u_upper=upper,
            sensing_zones=sensing_table(sensing_rows),
            comm_zones=comm_table(comm_rows),
        )

    def apply(self, q: ProblemInputs, controls: np.ndarray) -> None:
        """Move the robots and update the targets' information with their new positions."""
        u = np.clip(controls, q.u_lower, q.u_upper)
        self.positions = q.positions + u * DT
        info = measurement_information(self.positions, q.targets)
        self.info = q.prior_info + np.einsum("i,ijab->jab", q.sensing, info)
        self.step_index += 1

    def run(self, steps: int) -> Iterator[ProblemInputs]:
        """Yield the inputs of each step; the caller must :meth:`apply` controls in between."""
        for _ in range(steps):
            yield self.inputs()


def active_fraction(q: ProblemInputs, controls: np.ndarray, tol: float = 0.05) -> float:
    """Fraction of robots within ``tol`` of (or past) some known zone's keep-out boundary.

    Uses the chance constraints' keep-out margins without their slacks (eqs. 7c, 7d).
    """
    moved = replace(q, positions=q.positions + controls * q.dt)
    near = [bool(np.any(constraint_margins(moved, i) <= tol)) for i in range(len(moved.positions))]
    return float(np.mean(near))
