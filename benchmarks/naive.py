"""The naive reference: the league NLP as a user would write it with CasADi ``Opti``.

Written from docs/model.md §5 directly (it does not reuse the package's problem code, so it also
cross-checks it): numbers are baked into the expressions, the problem is rebuilt every step,
and IPOPT solves it from a cold start with its default settings.
"""

from __future__ import annotations

import time
from typing import Any

import casadi as ca
import numpy as np

from resilient_tracking.planning.layout import CommRow as C
from resilient_tracking.planning.layout import ProblemInputs, Weight
from resilient_tracking.planning.layout import SensingRow as S

EPS = 0.05  # the same distance regularisation as the planner's model


def _info(x: Any, p: np.ndarray, sensor: np.ndarray) -> tuple[Any, Any, Any]:
    """Hᵀ R⁻¹ H of a range and a bearing sensor at x looking at p (entries xx, xy, yy)."""
    dx, dy = p[0] - x[0], p[1] - x[1]
    d2 = dx**2 + dy**2 + EPS**2
    d = ca.sqrt(d2)
    r = sensor[0] * ca.exp(-sensor[1] * d) / d2
    b = sensor[2] * ca.exp(-sensor[3] * d) / d2**2
    return r * dx**2 + b * dy**2, (r - b) * dx * dy, r * dy**2 + b * dx**2


def _spread(x: Any, mu: np.ndarray, s: np.ndarray) -> tuple[Any, Any]:
    """Distance to mu (regularised) and √(2 âᵀ Σ â)."""
    v = mu - x
    dist = ca.sqrt(ca.sumsqr(v) + EPS**2)
    a = v / dist
    quad = a[0] ** 2 * s[0] + 2 * a[0] * a[1] * s[1] + a[1] ** 2 * s[2]
    return dist, ca.sqrt(2 * quad + 1e-9)


def solve(q: ProblemInputs) -> tuple[np.ndarray, dict[str, Any], float]:
    """Build and solve; returns (controls (n, 2), IPOPT stats, wall seconds incl. building)."""
    start = time.perf_counter()
    n, big_n = len(q.positions), len(q.targets)
    opti = ca.Opti()
    u = opti.variable(2, n)
    nu = opti.variable(len(q.sensing_zones), n) if len(q.sensing_zones) else None
    xi = opti.variable(len(q.comm_zones), n) if len(q.comm_zones) else None
    xp = [q.positions[i] + u[:, i] * q.dt for i in range(n)]
    w = q.weights
    trace = 0
    for j in range(big_n):
        a, b, c = q.prior_info[j, 0, 0], q.prior_info[j, 0, 1], q.prior_info[j, 1, 1]
        for i in range(n):
            if q.sensing[i]:
                ixx, ixy, iyy = _info(xp[i], q.targets[j], q.sensor)
                a, b, c = a + ixx, b + ixy, c + iyy
        trace = trace + (a + c) / (a * c - b * b)
    cost = w[Weight.TRACKING] * trace + w[Weight.EFFORT] * ca.sumsqr(u)
    if nu is not None:
        cost += w[Weight.SENSING_SLACK] * ca.sum1(ca.sum2(nu))
        opti.subject_to(ca.vec(nu) >= 0)
    if xi is not None:
        cost += w[Weight.COMM_SLACK] * ca.sum1(ca.sum2(xi))
        opti.subject_to(ca.vec(xi) >= 0)
    opti.minimize(cost)
    for i in range(n):
        opti.subject_to(opti.bounded(q.u_lower[i], u[:, i], q.u_upper[i]))
        for zl, z in enumerate(q.sensing_zones):
            dist, spread = _spread(xp[i], z[S.MEAN], z[S.GAUSSIAN][2:])
            assert nu is not None
            opti.subject_to(dist - z[S.R_SAFE] + nu[zl, i] >= z[S.BETA] * spread)
        for zk, z in enumerate(q.comm_zones):
            dist, spread = _spread(xp[i], z[C.MEAN], z[C.GAUSSIAN][2:])
            assert xi is not None
            for j in range(n):
                if j != i:
                    pair = ca.sqrt(ca.sumsqr(xp[i] - xp[j]) + EPS**2)
                    row = dist - z[C.DELTA2] * pair - z[C.CLEARANCE] + xi[zk, i]
                    opti.subject_to(row >= z[C.BETA] * spread)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes"})
    try:
        sol = opti.solve()
        controls = np.asarray(sol.value(u)).reshape(2, n).T
    except RuntimeError:  # a failed solve: report it, keep the last iterate
        controls = np.asarray(opti.debug.value(u)).reshape(2, n).T
    stats = dict(opti.stats())
    return controls, stats, time.perf_counter() - start
