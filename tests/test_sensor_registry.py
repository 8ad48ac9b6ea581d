"""The sensor registry: the scenario's ``sensor.type`` picks the measurement model, a section
without one is the paper's range-bearing sensor, and a sensor of another shape (here a
one-channel range-only sensor from outside the package, with no angle channel) runs through the
filter, the team and an episode."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import casadi as ca
import numpy as np
import pytest
from pydantic import Field

from helpers import shipped
from resilient_tracking import SENSORS, MeasurementModel, SensorSpec, Team
from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.models.sensor import PLAN_EPS, SensorChannel
from resilient_tracking.scenario import ScenarioError, parse_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.world.world import World


class RangeOnlySpec(SensorSpec):
    """A range-only sensor (a test sensor)."""

    range: SensorChannel = Field(SensorChannel(), description="Noise of the range.")


@dataclass(frozen=True)
class RangeOnlySensor(MeasurementModel):
    """The distance to a target, inverse variance ``peak · exp(−shape · d)`` (a test sensor)."""

    peak: float = 15.0
    shape: float = 0.2

    Spec: ClassVar[type[SensorSpec]] = RangeOnlySpec
    DIM: ClassVar[int] = 1
    ANGLES: ClassVar[tuple[int, ...]] = ()
    N_PARAMETERS: ClassVar[int] = 2

    @classmethod
    def from_spec(cls, spec: Any) -> RangeOnlySensor:
        return cls(spec.range.peak, spec.range.shape)

    @property
    def parameters(self) -> np.ndarray:
        return np.array([self.peak, self.shape])

    def predict(self, robot: np.ndarray, target: np.ndarray) -> np.ndarray:
        delta = np.asarray(target) - np.asarray(robot)
        return np.hypot(delta[..., 0], delta[..., 1])[..., None]

    def noise_variance(self, distance: Any) -> np.ndarray:
        return (np.exp(self.shape * np.asarray(distance, dtype=float)) / self.peak)[..., None]

    def noise_distance(self, robot: Any, target: Any, measurement: np.ndarray) -> np.ndarray:
        return measurement[..., 0]

    def jacobian(self, robot: np.ndarray, target: np.ndarray) -> np.ndarray:
        delta = np.asarray(target) - np.asarray(robot)
        d = np.maximum(np.hypot(delta[..., 0], delta[..., 1]), 1e-3)
        return (delta / d[..., None])[..., None, :]

    def in_range(self, distance: Any) -> np.ndarray:
        return np.ones_like(np.asarray(distance, dtype=float), dtype=bool)

    def sample(self, robot: Any, target: Any, rng: np.random.Generator) -> np.ndarray:
        clean = self.predict(robot, target)
        std = np.sqrt(self.noise_variance(clean[..., 0]))
        return clean + std * rng.standard_normal(clean.shape)

    def information(self, robot: Any, target: Any, eps: float = PLAN_EPS) -> np.ndarray:
        delta = np.asarray(target) - np.asarray(robot)
        dx, dy = delta[..., 0], delta[..., 1]
        d2 = dx * dx + dy * dy + eps**2
        info = self.peak * np.exp(-self.shape * np.sqrt(d2)) / d2
        return np.stack([info * dx * dx, info * dx * dy, info * dy * dy], axis=-1)

    @staticmethod
    def information_casadi(x: Any, p: Any, params: Any, eps: float = PLAN_EPS) -> Any:
        delta = p - x
        d2 = ca.sumsqr(delta) + eps**2
        info = params[0] * ca.exp(-params[1] * ca.sqrt(d2)) / d2
        return info * delta[0] ** 2, info * delta[0] * delta[1], info * delta[1] ** 2

    @staticmethod
    def information_derivatives_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        # a test sensor may let CasADi differentiate (the built-ins do it by hand)
        xs = ca.SX.sym("xs", 2)
        m = ca.vertcat(*RangeOnlySensor.information_casadi(xs, p, params, eps))
        rows = [ca.hessian(m[r], xs)[0] for r in range(3)]
        hess = ca.vertcat(*[ca.horzcat(h[0, 0], h[0, 1], h[1, 1]) for h in rows])
        f = ca.Function("f", [xs], [m, ca.jacobian(m, xs), hess])
        return f(x)


RANGE_ONLY = f"{__name__}:RangeOnlySensor"


def _data(sensor: dict) -> dict:
    data = shipped("sensing-temp").model_dump(mode="json")
    data["sensor"] = sensor
    return data


def test_a_sensor_section_without_a_type_is_the_range_bearing_sensor():
    scenario = parse_scenario(_data({"range": {"peak": 3.0}, "max_range": 4.0}))
    assert scenario.sensor.type == "range_bearing"
    assert scenario.sensor.model() == RangeBearingSensor(range_peak=3.0, max_range=4.0)
    assert parse_scenario(scenario.model_dump(mode="json")).sensor == scenario.sensor
    assert SENSORS.get("range_bearing") is RangeBearingSensor
    assert "range_bearing" in SENSORS.builtin_names()


def test_an_unknown_sensor_type_lists_the_known_ones():
    with pytest.raises(ScenarioError, match="sensor: unknown sensor 'sonar'; choose from .*range"):
        parse_scenario(_data({"type": "sonar"}))
    with pytest.raises(ScenarioError, match="sensor.bearing: Extra inputs"):
        parse_scenario(_data({"type": RANGE_ONLY, "bearing": {}}))


def test_the_sensor_type_picks_a_plugin_by_dotted_path():
    scenario = parse_scenario(_data({"type": RANGE_ONLY, "range": {"peak": 40.0}}))
    assert scenario.sensor.model() == RangeOnlySensor(peak=40.0)
    obs = World(scenario, 2).observe()
    assert obs.measurements.shape == (3, 3, 1)
    np.testing.assert_allclose(
        obs.measurements[..., 0],
        np.linalg.norm(
            obs.positions[:, None] - np.array([t.start for t in scenario.targets]), axis=-1
        ),
        atol=1.0,
    )


def test_the_filter_takes_the_sensors_channels_and_wraps_no_angle():
    sensor = RangeOnlySensor(peak=400.0, shape=0.0)
    ekf = ExtendedKalmanFilter(NearlyConstantVelocity(0.1, 0.1), sensor)
    robots = np.array([[-3.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    truth = np.array([[0.4, -0.2]])
    est = TargetEstimate.initial(np.array([[0.0, 0.0, 0.0, 0.0]]), 1.0, 0.3)
    # a range of 9 would be an angle of 9 − 2π: wrapping it would move the estimate far away
    far = np.array([[[9.0]], [[9.0]], [[9.0]]])
    moved = ekf.update(est, robots, far)
    assert np.linalg.norm(moved.mean[0, :2]) > 2.0
    z = sensor.predict(robots[:, None], truth[None])
    res = ekf.update_detailed(est, robots, z)
    assert np.linalg.norm(res.estimate.mean[0, :2] - truth[0]) < 0.1
    assert res.dof.tolist() == [3]
    with pytest.raises(ValueError, match=r"shape \(3, 1, 1\)"):
        ekf.update(est, robots, np.zeros((3, 1, 2)))


def test_a_team_refuses_measurements_of_another_sensor():
    scenario = parse_scenario(_data({"type": RANGE_ONLY}))
    team = Team.from_scenario(scenario, [t.start for t in scenario.targets], policy="vanilla")
    obs = World(shipped("sensing-temp"), 1).observe()  # range-bearing: two channels
    with pytest.raises(ValueError, match="the team's sensor measures 1 channel"):
        team.step(obs)


def test_an_episode_runs_with_a_plugin_sensor():
    data = _data({"type": RANGE_ONLY})
    data["steps"] = 8
    result = run_episode(parse_scenario(data), policy="vanilla")
    team = result["team"]
    assert len(team) == 8 and (team["n_solves"] > 0).all()
    assert np.isfinite(team[["mse", "trace"]].to_numpy()).all()
