"""A new sensor is one new class: the league NLP and the SOG program take any
:class:`MeasurementModel`, with however many parameters it has."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np

from helpers import automatic_derivatives, check_derivatives, inputs
from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.models.sensor import PLAN_EPS, FloatArray
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.planning.sog_problem import information_function


@dataclass(frozen=True)
class DimmedRangeBearing(RangeBearingSensor):
    """A range-bearing sensor whose information is scaled by a fifth parameter, ``gain``."""

    gain: float = 0.5
    N_PARAMETERS: ClassVar[int] = 5

    @property
    def parameters(self) -> FloatArray:
        return np.append(super().parameters, self.gain)

    def information(
        self, robot: FloatArray, target: FloatArray, eps: float = PLAN_EPS
    ) -> FloatArray:
        return self.gain * super().information(robot, target, eps)

    @staticmethod
    def information_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        xx, xy, yy = RangeBearingSensor.information_casadi(x, p, params[:4], eps)
        return params[4] * xx, params[4] * xy, params[4] * yy

    @staticmethod
    def information_derivatives_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        m, jac, hess = RangeBearingSensor.information_derivatives_casadi(x, p, params[:4], eps)
        return params[4] * m, params[4] * jac, params[4] * hess


def test_the_league_nlp_takes_a_new_sensor_class():
    base = inputs(3, 2, seed=1, sensing_zones=1, comm_zones=1)
    q = replace(
        base,
        sensor_model=DimmedRangeBearing,
        sensor=DimmedRangeBearing(gain=1.0).parameters,
    )
    structure = q.structure()
    assert structure.sensor_model is DimmedRangeBearing
    nlp = LeagueNLP(structure)
    pv = LeagueProblem(structure).pack_params(q)
    assert len(pv) == nlp.n_params == LeagueNLP(base.structure()).n_params + 1
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, structure.n_vars)
    check_derivatives(nlp, automatic_derivatives(nlp), x, pv, rng.uniform(-3, 1, nlp.n_constraints))
    # with gain 1 it is the range-bearing problem: same objective at the same point
    plain = LeagueNLP(base.structure())
    f_new = float(nlp.functions["fg"](x, pv)[0])
    f_old = float(plain.functions["fg"](x, LeagueProblem(base.structure()).pack_params(base))[0])
    assert f_new == f_old
    # and its gain reaches the tracking term
    dim = replace(q, sensor=DimmedRangeBearing(gain=0.5).parameters)
    dimmed = LeagueProblem(structure).pack_params(dim)
    assert float(nlp.functions["fg"](x, dimmed)[0]) > f_new


def test_the_sog_program_takes_a_new_sensor_class():
    x = np.array([[0.0, 1.0, -1.0], [0.0, 0.5, 0.2]])
    weight, targets = np.ones(3), np.array([[0.3, 1.5], [0.1, -0.4]])
    sensor = DimmedRangeBearing(gain=0.25)
    dimmed = information_function(3, 2, DimmedRangeBearing)(x, weight, targets, sensor.parameters)
    plain = information_function(3, 2)(x, weight, targets, RangeBearingSensor().parameters)
    np.testing.assert_allclose(dimmed.full(), 0.25 * plain.full(), rtol=1e-12)
