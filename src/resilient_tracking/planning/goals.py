"""Goals and cost-to-go of the route program: which target each robot heads for, and how.

Each robot that can sense is assigned a target (Hungarian assignment on route lengths; with
more robots than targets, a target's k-th robot pays ``k · spread`` more, so robots spread
over the targets first). Its goal is where that target is predicted to be when the robot
arrives (at most ``lookahead`` ahead), moved out of any keep-out disc it falls in. The
planner's objective then gains, per robot, a pull along the shortest route to its goal::

    c_i · hinge(‖x_i⁺ − w_i‖ + L_i − reach),   hinge(e) = (e + √(e² + ε²)) / 2

with ``w_i`` the route's next waypoint and ``L_i`` the route length after it. Within
``reach`` of its goal a robot feels no pull and the paper's tracking objective alone decides
where it stands; far away the pull is a constant force ``c_i`` along the route, and
``c_i = 2 w2 v_i / dt`` makes it balance the effort term ``w2 ‖u_i‖²`` at the speed
``v_i = speed · u_max,i``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import linear_sum_assignment

from resilient_tracking.planning.layout import CommRow, RouteRow, SensingRow
from resilient_tracking.planning.route import RouteMap
from resilient_tracking.planning.spec import RouteSpec

#: Resolution (m) of the teammate distance in a comm zone's keep-out disc.
PAIR_STEP = 0.25


def keep_out_discs(sensing_rows: np.ndarray, comm_rows: np.ndarray, pair: float) -> np.ndarray:
    """Discs ``(x, y, radius)`` enclosing where the known zones' chance constraints bind.

    A sensing row (eq. 7c) keeps ``r_safe + β √(2 âᵀΣâ)`` from the zone's mean, at most
    ``r_safe + β √(2 λ_max)``; a comm row (eq. 7d) adds ``δ2`` times the distance to a
    teammate, taken as ``pair`` rounded up to ``PAIR_STEP`` (so that the discs, and the route
    map built from them, change only when the league's spacing does), and its clearance.
    """
    pair = PAIR_STEP * math.ceil(pair / PAIR_STEP)
    discs = []
    for row in np.asarray(sensing_rows).reshape(-1, SensingRow.WIDTH):
        radius = row[SensingRow.R_SAFE] + row[SensingRow.BETA] * _spread(row[SensingRow.COVARIANCE])
        discs.append([*row[SensingRow.MEAN], radius])
    for row in np.asarray(comm_rows).reshape(-1, CommRow.WIDTH):
        spread = _spread(row[CommRow.COVARIANCE])
        radius = row[CommRow.CLEARANCE] + row[CommRow.BETA] * spread + row[CommRow.DELTA2] * pair
        discs.append([*row[CommRow.MEAN], radius])
    return np.array(discs, dtype=float).reshape(-1, 3)


def _spread(sigma: np.ndarray) -> float:
    cov = np.array([[sigma[0], sigma[1]], [sigma[1], sigma[2]]])
    return float(np.sqrt(2 * max(np.linalg.eigvalsh(cov)[-1], 0.0)))


def assign(lengths: np.ndarray, spread: float) -> np.ndarray:
    """Target index per robot (rows of ``lengths``), minimising the summed route length."""
    n, big_n = lengths.shape
    copies = -(-n // big_n)
    cost = np.concatenate([lengths + k * spread for k in range(copies)], axis=1)
    cost = np.where(np.isfinite(cost), cost, 1e9)
    rows, cols = linear_sum_assignment(cost)
    out = np.empty(n, dtype=int)
    out[rows] = cols % big_n
    return out


def route_rows(
    positions: np.ndarray,
    can_sense: np.ndarray,
    targets: np.ndarray,
    velocities: np.ndarray,
    routes: RouteMap,
    u_max: np.ndarray,
    w_effort: float,
    dt: float,
    params: RouteSpec,
) -> np.ndarray:
    """Route rows ``(waypoint x, y, offset, weight)`` per robot; robots that cannot sense get
    weight 0 (no tracking to go to)."""
    n = len(positions)
    rows = np.zeros((n, RouteRow.WIDTH))
    rows[:, RouteRow.WAYPOINT] = positions
    sensing = np.flatnonzero(np.asarray(can_sense) > 0)
    if not len(sensing) or not len(targets):
        return rows
    # a robot inside a keep-out disc (a zone just learned, or wedged where two discs overlap)
    # is routed from the nearest point outside: routing from inside would let the disc that
    # holds it block nothing, and send it straight through discs it cannot cross
    starts = routes.outside(positions[sensing])
    lengths = routes.lengths(starts, routes.outside(targets))
    chosen = assign(lengths, params.spread)
    speed = params.speed * np.asarray(u_max, dtype=float)[sensing]
    ahead = np.minimum(
        lengths[np.arange(len(sensing)), chosen] / np.maximum(speed, 1e-6), params.lookahead
    )
    goals = routes.outside(targets[chosen] + velocities[chosen] * ahead[:, None])
    waypoints, remaining = routes.routes(starts, goals)
    rows[sensing, RouteRow.WAYPOINT] = waypoints
    rows[sensing, RouteRow.OFFSET] = remaining - params.reach
    rows[sensing, RouteRow.WEIGHT] = 2 * w_effort * speed / dt
    return rows
