"""The league NLP's pieces as small CasADi functions that return their own derivatives.

The objective and constraints of the league NLP (docs/model.md §5, paper eqs. 6 and 7) are
sums of small pieces — one robot–target information term, one robot–zone keep-out margin, one
robot–robot distance — so the NLP assembles its derivatives from the pieces' derivatives
(:mod:`~resilient_tracking.planning.nlp`) instead of differentiating the whole graph.
"""

from __future__ import annotations

from typing import Any

import casadi as ca

from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.models.sensor import PLAN_EPS, MeasurementModel
from resilient_tracking.planning.layout import RouteRow
from resilient_tracking.planning.margins import keep_out, pair_distance

#: Smoothing (m) of the route program's distance and hinge.
ROUTE_EPS = 0.2


def trace_of_inverse(a: Any, b: Any, c: Any) -> Any:
    """``tr [[a, b], [b, c]]⁻¹``."""
    return (a + c) / (a * c - b * b)


def route_pull(xp: Any, row: Any) -> Any:
    """The route program's cost-to-go of one robot (:mod:`~.goals`): ``c · h(‖x⁺ − w‖ +
    offset)`` with ``h(e) = (e + √(e² + ε²)) / 2`` a smooth hinge and ``row`` a
    :class:`~.layout.RouteRow` ``(w, offset, c)``."""
    e = ca.sqrt(ca.sumsqr(xp - row[RouteRow.WAYPOINT]) + ROUTE_EPS**2) + row[RouteRow.OFFSET]
    return row[RouteRow.WEIGHT] * 0.5 * (e + ca.sqrt(e * e + ROUTE_EPS**2))


def piece_functions(
    sensor: type[MeasurementModel] = RangeBearingSensor, standoff: float = PLAN_EPS
) -> dict[str, ca.Function]:
    """SX functions (CSE applied), each returning a piece and its derivatives:

    * ``info(x⁺, p, sensor) → m, ∂m/∂x⁺, ∂²m/∂x⁺²``: the sensor's information at ``x⁺``
      (distances regularised by ``standoff``);
    * ``trace(abc) → F, ∇F, ∇²F`` of :func:`trace_of_inverse`;
    * ``keep_out(x⁺, zone, offset, β) → h, ∇h, ∇²h`` (:func:`~.margins.keep_out`);
    * ``pair(x⁺, x_q⁺) → ρ, ∇ρ, ∇²ρ`` w.r.t. ``x⁺`` (:func:`~.margins.pair_distance`);
    * ``route(x⁺, row) → c h, ∇, ∇²`` w.r.t. ``x⁺`` (:func:`route_pull`).
    """
    sx = ca.SX.sym

    def function(name: str, inputs: list[Any], outputs: list[Any]) -> ca.Function:
        return ca.Function(name, inputs, ca.cse(outputs))

    xp, p, params = sx("xp", 2), sx("p", 2), sx("sensor", sensor.N_PARAMETERS)
    info = function(
        "info",
        [xp, p, params],
        list(sensor.information_derivatives_casadi(xp, p, params, standoff)),
    )
    abc = sx("abc", 3)
    f = trace_of_inverse(abc[0], abc[1], abc[2])
    hess_f, grad_f = ca.hessian(f, abc)
    trace = function("trace", [abc], [f, grad_f, hess_f])
    zone, offset, beta = sx("zone", 5), sx("offset"), sx("beta")
    h = keep_out(xp, zone, offset, beta)
    keep_out_fn = function(
        "keep_out", [xp, zone, offset, beta], [h, ca.gradient(h, xp), ca.hessian(h, xp)[0]]
    )
    xq = sx("xq", 2)
    pair = pair_distance(xp, xq)
    pair_fn = function("pair", [xp, xq], [pair, ca.gradient(pair, xp), ca.hessian(pair, xp)[0]])
    row = sx("route", RouteRow.WIDTH)
    pull = route_pull(xp, row)
    route = function("route", [xp, row], [pull, ca.gradient(pull, xp), ca.hessian(pull, xp)[0]])
    return {
        "info": info,
        "trace": trace,
        "keep_out": keep_out_fn,
        "pair": pair_fn,
        "route": route,
    }
