"""The one-step league NLP (docs/model.md §5, paper eqs. 6 and 9), built once per structure,
solved many times.

Decision variables per league robot ``i``: velocity ``u_i``, slacks ``ν_il ≥ 0`` per known
sensing zone and ``ξ_ik ≥ 0`` per known comm zone::

    min  w1 Σ_j tr P⁺_j(x⁺) + Σ_i [w2 ‖u_i‖² + w3 Σ_l ν_il + w4 Σ_k ξ_ik]
    s.t. ‖x_i⁺ − μ_S‖ − r_safe + ν_il ≥ β1 √(2 âᵀ Σ_S â)                  (eq. 7c)
         ‖x_i⁺ − μ_C‖ − δ2 ‖x_i⁺ − x_j⁺‖ − c_k + ξ_ik ≥ β2 √(2 âᵀ Σ_C â)  ∀ j ≠ i  (eq. 7d)

with ``x_i⁺ = x_i + u_i dt``, ``β = erfinv(1 − 2ε)`` and ``â`` the regularised unit vector from
``x_i⁺`` to ``μ``. ``c_k`` is an extra clearance (0 for a zone known from an attack clue; set
for a zone inferred from a circling robot, whose ``δ2`` nobody saw). ``P⁺_j`` is the position
block of the one-step EKF posterior: the predicted position information plus ``s_i Hᵀ R⁻¹ H``
of every robot (``s_i = 1`` when it can sense).
The velocity bounds and the workspace become simple bounds on ``u``.

Everything that changes from step to step — positions, sensing mask, estimates, weights, zone
parameters — is a parameter, so one cached problem serves every step of a given structure.

**Derivatives by structure.** The objective and constraints are sums of small pieces — one
robot–target information term, one robot–zone keep-out, one robot–robot distance — so their
derivatives are assembled from the derivatives of the pieces (derived by hand or by CasADi on a
handful of symbols) instead of differentiating the whole graph; this roughly halves the
Hessian's cost at 20 robots. With ``A_j = prior_j + Σ_i s_i m_ij`` and ``F_j = tr A_j⁻¹`` as a
function of ``(a, b, c)``, the tracking term's Hessian is::

    ∂²F_j/∂x_i∂x_k = s_i s_k M_ijᵀ ∇²F_j M_kj + δ_ik s_i Σ_m ∂F_j/∂m · ∇²m_ij

(``M_ij`` the 3×2 Jacobian of ``m_ij``). The first part is positive semidefinite (``tr A⁻¹`` is
convex in ``A``); the 2×2 diagonal blocks carry the rest, which is indefinite near a target
(the bearing information peaks on a ring of radius ``PLAN_EPS`` around it), together with the
keep-out curvature. The SQP therefore uses the exact Hessian with each robot's 2×2 diagonal
block's eigenvalues clipped from below (closed form), IPOPT the exact Hessian.

**The SQP's reduced problem.** Within one step a robot moves at most ``u_max dt``, so most
rows can never bind: zones far from a robot, and for the jamming rows every teammate but the
farthest few. qpOASES pays for every slack at its bound and every row in each QP (it rebuilds
its factorisation from the previous working set for every new Hessian and Jacobian), so for
large leagues the SQP solves a problem with a fixed number of *slots* per robot
(:class:`Slots`) whose zone and teammate are parameters, filled each step with what can
bind; what is left out provably holds (:meth:`LeagueProblem.reduction`). Same solutions,
same structure every step.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import logging
import os
from collections.abc import Iterator
from dataclasses import astuple, dataclass
from typing import Any

import casadi as ca
import numpy as np

from resilient_tracking.planning import codegen
from resilient_tracking.planning.cache import LruCache

log = logging.getLogger(__name__)

#: Distance regularisation (m) in the planner's information model and in â.
PLAN_EPS = 0.05
#: Keeps √(2 âᵀΣâ) differentiable where â vanishes (a robot exactly on a zone's mean).
SPREAD_EPS = 1e-9
#: Columns of a sensing-zone row: mu(2), sigma xx/xy/yy, r_safe, beta1.
SENSING_COLUMNS = 7
#: Columns of a comm-zone row: mu(2), sigma xx/xy/yy, delta2, beta2, clearance.
COMM_COLUMNS = 8
#: Smoothing (m) of the route program's distance and hinge.
ROUTE_EPS = 0.2
#: Columns of a route row: waypoint x, y, offset, weight (:mod:`~.goals`).
ROUTE_COLUMNS = 4
#: Curvature put on the slack variables in the SQP's Hessian (they enter linearly).
SLACK_CURVATURE = 1e-6

#: Solver plugins a problem can be solved with.
METHODS = ("sqp", "ipopt")


@dataclass(frozen=True)
class Structure:
    """What changes the symbolic problem: sizes, and the planner program.

    ``route`` adds the route program's cost-to-go term (one :data:`ROUTE_COLUMNS` row of
    parameters per robot, see :mod:`resilient_tracking.planning.goals`); ``standoff`` is the
    distance regularisation (m) of the information model, :data:`PLAN_EPS` in the paper's
    one-step program.
    """

    n_robots: int
    n_targets: int
    n_sensing_zones: int = 0
    n_comm_zones: int = 0
    route: bool = False
    standoff: float = PLAN_EPS

    @property
    def label(self) -> str:
        """A short name for compiled code and logs."""
        sizes = f"{self.n_robots}x{self.n_targets}_{self.n_sensing_zones}s{self.n_comm_zones}c"
        route = f"_route{round(self.standoff * 1000)}mm" if self.route else ""
        return f"league_{sizes}{route}"

    @property
    def n_vars(self) -> int:
        return self.n_robots * (2 + self.n_sensing_zones + self.n_comm_zones)

    @property
    def n_constraints(self) -> int:
        n = self.n_robots
        return n * self.n_sensing_zones + n * self.n_comm_zones * (n - 1)


@dataclass(frozen=True)
class Slots:
    """Sizes of the SQP's reduced problem (:meth:`LeagueProblem.reduction`): per robot,
    ``sensing`` sensing-zone rows, ``comm`` comm-zone slacks with ``mates`` teammate rows
    each; which zone and teammate fill each slot is a parameter."""

    sensing: int
    comm: int
    mates: int


@dataclass
class ProblemInputs:
    """Numeric values for one solve."""

    positions: np.ndarray  # (n, 2)
    sensing: np.ndarray  # (n,) 1.0 if robot can sense
    targets: np.ndarray  # (N, 2) predicted target positions at t+1
    prior_info: np.ndarray  # (N, 2, 2) predicted position-block information P⁻¹
    weights: np.ndarray  # (4,) w1..w4
    sensor: np.ndarray  # (4,) range peak, range shape, bearing peak, bearing shape
    dt: float
    u_lower: np.ndarray  # (n, 2)
    u_upper: np.ndarray  # (n, 2)
    sensing_zones: np.ndarray  # (L, 7): mu(2), sigma xx/xy/yy, r_safe, beta1
    comm_zones: np.ndarray  # (K, 8): mu(2), sigma xx/xy/yy, delta2, beta2, clearance
    #: (n, 4) route rows (waypoint x, y, offset, weight) of the route program, else None
    route: np.ndarray | None = None


# ---------------------------------------------------------------------------- model pieces


def _unit_and_norm(v: Any) -> tuple[Any, Any]:
    norm = ca.sqrt(ca.sumsqr(v) + PLAN_EPS**2)
    return v / norm, norm


def _quad(a: Any, sxx: Any, sxy: Any, syy: Any) -> Any:
    return a[0] * a[0] * sxx + 2 * a[0] * a[1] * sxy + a[1] * a[1] * syy


def measurement_information(
    x: Any, p: Any, sensor: Any, eps: float = PLAN_EPS
) -> tuple[Any, Any, Any]:
    """Entries (xx, xy, yy) of ``Hᵀ R⁻¹ H`` for a range-bearing sensor at ``x`` seeing ``p``."""
    delta = p - x
    d2 = ca.sumsqr(delta) + eps**2
    d = ca.sqrt(d2)
    info_r = sensor[0] * ca.exp(-sensor[1] * d) / d2  # range row is δᵀ/d
    info_b = sensor[2] * ca.exp(-sensor[3] * d) / (d2 * d2)  # bearing row is [−δy, δx]/d²
    dx, dy = delta[0], delta[1]
    return (
        info_r * dx * dx + info_b * dy * dy,
        (info_r - info_b) * dx * dy,
        info_r * dy * dy + info_b * dx * dx,
    )


def trace_of_inverse(a: Any, b: Any, c: Any) -> Any:
    """``tr [[a, b], [b, c]]⁻¹``."""
    return (a + c) / (a * c - b * b)


def sensing_margin(xp: Any, z: Any) -> Any:
    """Left side of eq. 7c without the slack: ``‖x⁺ − μ‖ − r_safe − β1 √(2 âᵀΣâ)``."""
    ahat, dist = _unit_and_norm(z[0:2] - xp)
    spread = ca.sqrt(2 * _quad(ahat, z[2], z[3], z[4]) + SPREAD_EPS)
    return dist - z[5] - z[6] * spread


def comm_margin(xp: Any, xq: Any, z: Any) -> Any:
    """Left side of eq. 7d without the slack, for robot ``x⁺`` and teammate ``x_q⁺``."""
    ahat, dist = _unit_and_norm(z[0:2] - xp)
    spread = ca.sqrt(2 * _quad(ahat, z[2], z[3], z[4]) + SPREAD_EPS)
    pair = ca.sqrt(ca.sumsqr(xp - xq) + PLAN_EPS**2)
    return dist - z[5] * pair - z[7] - z[6] * spread


def _info_pieces(xp: Any, p: Any, sensor: Any, eps: float = PLAN_EPS) -> tuple[Any, Any, Any]:
    """``m = (xx, xy, yy)`` of :func:`measurement_information`, its Jacobian ``∂m/∂x`` (3×2)
    and its Hessians (3×3: row ``r`` holds ``∂²m_r/∂x²`` as ``[xx, xy, yy]``), by hand.

    ``m = φ_r(ρ) v_r(δ) + φ_b(ρ) v_b(δ)`` with ``δ = p − x``, ``ρ = ‖δ‖² + ε²``,
    ``φ(ρ) = peak e^{−shape √ρ} ρ^{−k}`` (``k = 1`` range, ``2`` bearing),
    ``v_r = (δx², δxδy, δy²)`` and ``v_b = (δy², −δxδy, δx²)``.
    """
    dx, dy = p[0] - xp[0], p[1] - xp[1]
    rho = dx * dx + dy * dy + eps**2
    root = ca.sqrt(rho)
    v = {"r": (dx * dx, dx * dy, dy * dy), "b": (dy * dy, -dx * dy, dx * dx)}
    # ∂v/∂δx, ∂v/∂δy and the constant second derivatives (xx, xy, yy)
    dv = {"r": ((2 * dx, dy, 0), (0, dx, 2 * dy)), "b": ((0, -dy, 2 * dx), (2 * dy, -dx, 0))}
    ddv = {"r": ((2, 0, 0), (0, 1, 0), (0, 0, 2)), "b": ((0, 0, 2), (0, -1, 0), (2, 0, 0))}
    m = [0, 0, 0]
    jac = [[0, 0], [0, 0], [0, 0]]  # w.r.t. δ
    hess = [[0, 0, 0], [0, 0, 0], [0, 0, 0]]  # w.r.t. δ: xx, xy, yy
    d = (dx, dy)
    for channel, peak, shape, k in (("r", sensor[0], sensor[1], 1), ("b", sensor[2], sensor[3], 2)):
        phi = peak * ca.exp(-shape * root) / (rho if k == 1 else rho * rho)
        l1 = -shape / (2 * root) - k / rho
        phi1 = phi * l1
        phi2 = phi * (l1 * l1 + shape / (4 * rho * root) + k / (rho * rho))
        for r in range(3):
            vr = v[channel][r]
            m[r] = m[r] + phi * vr
            for a in range(2):
                jac[r][a] = jac[r][a] + 2 * phi1 * d[a] * vr + phi * dv[channel][a][r]
            for e, (a, b) in enumerate(((0, 0), (0, 1), (1, 1))):
                term = 4 * phi2 * d[a] * d[b] * vr + phi * ddv[channel][e][r]
                term = term + 2 * phi1 * (
                    (vr if a == b else 0) + d[a] * dv[channel][b][r] + d[b] * dv[channel][a][r]
                )
                hess[r][e] = hess[r][e] + term
    # x = p − δ: the Jacobian flips sign, the Hessian does not
    jac_x = ca.vertcat(*[ca.horzcat(-jac[r][0], -jac[r][1]) for r in range(3)])
    hess_x = ca.vertcat(*[ca.horzcat(*hess[r]) for r in range(3)])
    return ca.vertcat(*m), jac_x, hess_x


def _keep_out(xp: Any, z: Any, offset: Any, beta: Any) -> Any:
    """``‖x⁺ − μ‖ − offset − β √(2 âᵀΣâ)`` for a zone row ``z`` (mu, sigma xx/xy/yy first)."""
    ahat, dist = _unit_and_norm(z[0:2] - xp)
    spread = ca.sqrt(2 * _quad(ahat, z[2], z[3], z[4]) + SPREAD_EPS)
    return dist - offset - beta * spread


def _route_pull(xp: Any, row: Any) -> Any:
    """The route program's cost-to-go of one robot (see :mod:`~.goals`): ``c · hinge(‖x⁺ −
    w‖ + offset)`` with ``hinge(e) = (e + √(e² + ε²)) / 2``, ``row = (w_x, w_y, offset, c)``."""
    e = ca.sqrt(ca.sumsqr(xp - row[0:2]) + ROUTE_EPS**2) + row[2]
    return row[3] * 0.5 * (e + ca.sqrt(e * e + ROUTE_EPS**2))


def _piece_functions(standoff: float = PLAN_EPS) -> dict[str, ca.Function]:
    """Small SX functions with the derivatives of each piece of the NLP (CSE applied)."""
    sx = ca.SX.sym

    def function(name: str, inputs: list[Any], outputs: list[Any]) -> ca.Function:
        return ca.Function(name, inputs, ca.cse(outputs))

    xp, p, sensor = sx("xp", 2), sx("p", 2), sx("sensor", 4)
    info = function("info", [xp, p, sensor], list(_info_pieces(xp, p, sensor, standoff)))
    abc = sx("abc", 3)
    f = trace_of_inverse(abc[0], abc[1], abc[2])
    hess_f, grad_f = ca.hessian(f, abc)
    trace = function("trace", [abc], [f, grad_f, hess_f])
    zone, offset, beta = sx("zone", 5), sx("offset"), sx("beta")
    h = _keep_out(xp, zone, offset, beta)
    keep_out = function(
        "keep_out", [xp, zone, offset, beta], [h, ca.gradient(h, xp), ca.hessian(h, xp)[0]]
    )
    xq = sx("xq", 2)
    pair = ca.sqrt(ca.sumsqr(xp - xq) + PLAN_EPS**2)
    pair_fn = function("pair", [xp, xq], [pair, ca.gradient(pair, xp), ca.hessian(pair, xp)[0]])
    row = sx("route", ROUTE_COLUMNS)
    pull = _route_pull(xp, row)
    route = function(
        "route", [xp, row], [pull, ca.gradient(pull, xp), ca.hessian(pull, xp)[0]]
    )
    return {
        "info": info,
        "trace": trace,
        "keep_out": keep_out,
        "pair": pair_fn,
        "route": route,
    }


# ---------------------------------------------------------------------------- the problem


def _sym2(e: Any) -> Any:
    """A symmetric 2×2 SX from ``[xx, xy, yy]``."""
    return ca.vertcat(ca.horzcat(e[0], e[1]), ca.horzcat(e[1], e[2]))


def _psd_clip(block: Any, margin: float) -> Any:
    """A symmetric 2×2 SX ``block`` with its eigenvalues ``λ`` replaced by ``h(λ) = max(λ,
    margin)``, in closed form: ``h(λ₋) I + (h(λ₊) − h(λ₋)) / (λ₊ − λ₋) · (B − λ₋ I)``."""
    p, q, r = block[0, 0], block[0, 1], block[1, 1]
    half_gap = ca.sqrt(0.25 * (p - r) ** 2 + q * q)
    mid = 0.5 * (p + r)
    lo, hi = mid - half_gap, mid + half_gap

    def h(lam: Any) -> Any:
        return ca.fmax(lam, margin)

    slope = (h(hi) - h(lo)) / ca.fmax(2 * half_gap, 1e-300)
    return h(lo) * ca.SX.eye(2) + slope * (block - lo * ca.SX.eye(2))


class LeagueNLP:
    """Symbolic NLP of one :class:`Structure` with structured first and second derivatives.

    Functions (all SX, inputs ``x, p`` and for Hessians ``lam_f, lam_g``):
    ``fg`` → (f, g); ``grad_f`` → (f, ∇f); ``jac_g`` → (g, ∂g/∂x); ``jac_fg`` → (f, ∇f, g, ∂g/∂x);
    ``hess_exact`` → the exact Hessian of the Lagrangian ``lam_f f + lam_gᵀ g`` (full symmetric),
    ``hess_exact_triu`` its upper triangle; ``hess_clip`` → the SQP's Hessian: exact, each
    robot's 2×2 diagonal block clipped to eigenvalues ≥ ``margin``, slacks given a tiny
    curvature (see the module docstring).
    """

    def __init__(self, structure: Structure, margin: float = 1e-2, slots: Slots | None = None):
        self.structure = s = structure
        self.margin = margin
        self.slots = slots
        n, big_n, nl, nk = s.n_robots, s.n_targets, s.n_sensing_zones, s.n_comm_zones
        # slack variables per robot: one per zone, or one per slot of the reduced problem
        n_nu, n_xi = (slots.sensing, slots.comm) if slots else (nl, nk)
        sx = ca.SX.sym
        u = sx("u", 2, n)
        nu = sx("nu", n_nu, n)
        xi = sx("xi", n_xi, n)
        x0 = sx("x", 2, n)
        sense = sx("s", n)
        targets = sx("targets", 2, big_n)
        prior = sx("prior", 3, big_n)
        w = sx("w", 4)
        sensor = sx("sensor", 4)
        dt = sx("dt")
        szones = sx("szones", SENSING_COLUMNS, nl)
        czones = sx("czones", COMM_COLUMNS, nk)
        self.x = x = ca.veccat(u, nu, xi)
        parameters = [x0, sense, targets, prior, w, sensor, dt, szones, czones]
        if s.route:
            route_rows = sx("route", ROUTE_COLUMNS, n)
            parameters.append(route_rows)
        if slots:
            # one-hot (or, for an unused slot, zero) columns: slot s of robot i is column
            # i·S + s; teammates are numbered without robot i
            ssel = sx("ssel", nl, n * slots.sensing)
            csel = sx("csel", nk, n * slots.comm)
            msel = sx("msel", n - 1, n * slots.mates)
            parameters += [ssel, csel, msel]
        self.p = p = ca.veccat(*parameters)
        self.n_params = int(p.shape[0])
        self.n_vars = nx = int(x.shape[0])
        pieces = _piece_functions(s.standoff)
        xp = x0 + u * dt
        xps = [xp[:, i] for i in range(n)]

        def iu(i: int) -> int:  # index of u_i[0] in x
            return 2 * i

        def inu(i: int, zl: int) -> int:
            return 2 * n + i * n_nu + zl

        def ixi(i: int, zk: int) -> int:
            return 2 * n + n * n_nu + i * n_xi + zk

        # ---- tracking term: f, ∇f and the two parts of its Hessian (w.r.t. x⁺)
        track = ca.SX(0)
        grad_xp = [ca.SX.zeros(2) for _ in range(n)]
        #: Σ_j s_i s_q M_ijᵀ ∇²F_j M_qj for q ≥ i (PSD as a whole)
        gn: dict[tuple[int, int], Any] = {}
        own = [ca.SX.zeros(2, 2) for _ in range(n)]  # Σ_j s_i Σ_m ∂F/∂m ∇²m_ij
        for j in range(big_n):
            parts = [pieces["info"](xps[i], targets[:, j], sensor) for i in range(n)]
            abc = prior[:, j]
            for i in range(n):
                abc = abc + sense[i] * parts[i][0]
            f_j, g_j, h_j = pieces["trace"](abc)
            track = track + f_j
            jacs = [sense[i] * parts[i][1] for i in range(n)]  # 3 × 2 each
            for i in range(n):
                left = ca.mtimes(jacs[i].T, h_j)  # 2 × 3
                for q in range(i, n):
                    gn[i, q] = gn.get((i, q), 0) + ca.mtimes(left, jacs[q])
                grad_xp[i] = grad_xp[i] + ca.mtimes(jacs[i].T, g_j)
                own[i] = own[i] + sense[i] * _sym2(ca.mtimes(parts[i][2].T, g_j))
        f = w[0] * track + w[1] * ca.sumsqr(u)
        # the route program's cost-to-go: its gradient and curvature w.r.t. x⁺, per robot
        pulls = [pieces["route"](xps[i], route_rows[:, i]) for i in range(n)] if s.route else []
        for pull in pulls:
            f = f + pull[0]
        grad = [ca.SX(0)] * nx
        for i in range(n):
            gi = w[0] * dt * grad_xp[i] + 2 * w[1] * u[:, i]
            if pulls:
                gi = gi + dt * pulls[i][1]
            grad[iu(i)], grad[iu(i) + 1] = gi[0], gi[1]
        if slots:  # a slot's slack costs only if the slot is in use (its column sums to 1)
            nu_cost = [ca.sum1(ssel[:, c]) for c in range(n * n_nu)]
            xi_cost = [ca.sum1(csel[:, c]) for c in range(n * n_xi)]
            f += w[2] * ca.dot(ca.vertcat(*nu_cost), ca.vec(nu)) if n_nu else 0
            f += w[3] * ca.dot(ca.vertcat(*xi_cost), ca.vec(xi)) if n_xi else 0
            for i in range(n):
                for zl in range(n_nu):
                    grad[inu(i, zl)] = w[2] * nu_cost[i * n_nu + zl]
                for zk in range(n_xi):
                    grad[ixi(i, zk)] = w[3] * xi_cost[i * n_xi + zk]
        else:
            if nl:
                f += w[2] * ca.sum1(ca.sum2(nu))
            if nk:
                f += w[3] * ca.sum1(ca.sum2(xi))
            for i in range(n):
                for zl in range(nl):
                    grad[inu(i, zl)] = w[2]
                for zk in range(nk):
                    grad[ixi(i, zk)] = w[3]

        # ---- constraints, their Jacobian and curvature pieces (w.r.t. x⁺)
        g: list[Any] = []
        jrows: list[int] = []
        jcols: list[int] = []
        jvals: list[Any] = []
        row_own: list[tuple[int, int, Any]] = []  # (row, robot, 2×2 curvature)
        #: (row, i, [(q, weight)], δ2 · ∇²‖x_i − x_p‖) with x_p = Σ_q weight x_q (one-hot)
        row_pair: list[tuple[int, int, list[tuple[int, Any]], Any]] = []

        def sensing_row(i: int, z: Any, slack: int) -> None:
            h, dh, ddh = pieces["keep_out"](xps[i], z[0:5], z[5], z[6])
            r = len(g)
            g.append(h + x[slack])
            jrows.extend([r, r, r])
            jcols.extend([iu(i), iu(i) + 1, slack])
            jvals.extend([dt * dh[0], dt * dh[1], ca.SX(1)])
            row_own.append((r, i, ddh))

        if not slots:
            pairs: dict[tuple[int, int], Any] = {}
            if nk:
                for i in range(n):
                    for q in range(i + 1, n):
                        pairs[i, q] = pieces["pair"](xps[i], xps[q])
            for i in range(n):
                for zl in range(nl):
                    sensing_row(i, szones[:, zl], inu(i, zl))
                for zk in range(nk):
                    z = czones[:, zk]
                    h, dh, ddh = pieces["keep_out"](xps[i], z[0:5], z[7], z[6])
                    for q in range(n):
                        if q == i:
                            continue
                        value, grad_pair, hess_pair = pairs[min(i, q), max(i, q)]
                        # ∂‖x_i − x_q‖/∂x_i = grad_pair if i < q, −grad_pair otherwise
                        gp = grad_pair if i < q else -grad_pair
                        r = len(g)
                        g.append(h - z[5] * value + xi[zk, i])
                        di, dq = dh - z[5] * gp, z[5] * gp
                        jrows += [r, r, r, r, r]
                        jcols += [iu(i), iu(i) + 1, iu(q), iu(q) + 1, ixi(i, zk)]
                        jvals += [dt * di[0], dt * di[1], dt * dq[0], dt * dq[1], ca.SX(1)]
                        row_own.append((r, i, ddh))
                        row_pair.append((r, i, [(q, ca.SX(1))], z[5] * hess_pair))
        else:
            # the reduced problem: zones and teammates picked by the one-hot parameters
            for i in range(n):
                for zl in range(n_nu):
                    sensing_row(i, ca.mtimes(szones, ssel[:, i * n_nu + zl]), inu(i, zl))
                mate_pairs = []
                for k in range(slots.mates):
                    weights = msel[:, i * slots.mates + k]
                    mates = [(q, weights[q - (q > i)]) for q in range(n) if q != i]
                    partner = ca.mtimes(ca.horzcat(*[xps[q] for q, _ in mates]), weights)
                    mate_pairs.append((mates, pieces["pair"](xps[i], partner)))
                for zk in range(n_xi):
                    z = ca.mtimes(czones, csel[:, i * n_xi + zk])
                    h, dh, ddh = pieces["keep_out"](xps[i], z[0:5], z[7], z[6])
                    for mates, (value, gp, hess_pair) in mate_pairs:
                        r = len(g)
                        g.append(h - z[5] * value + xi[zk, i])
                        di, dq = dh - z[5] * gp, z[5] * gp
                        jrows.extend([r] * (2 * n + 1))
                        jcols.extend([iu(i), iu(i) + 1, ixi(i, zk)])
                        jvals.extend([dt * di[0], dt * di[1], ca.SX(1)])
                        for q, wq in mates:
                            jcols.extend([iu(q), iu(q) + 1])
                            jvals.extend([wq * dt * dq[0], wq * dt * dq[1]])
                        row_own.append((r, i, ddh))
                        row_pair.append((r, i, mates, z[5] * hess_pair))
        ng = len(g)
        self.n_constraints = ng
        g_vec = ca.vertcat(*g) if g else ca.SX(0, 1)
        jac = ca.SX.triplet(jrows, jcols, ca.vertcat(*jvals), ng, nx) if ng else ca.SX(0, nx)

        # ---- Hessians of the Lagrangian lam_f f + lam_gᵀ g, w.r.t. x = (u, ν, ξ)
        lam_f = sx("lam_f")
        lam_g = sx("lam_g", ng)
        diag_rest = [lam_f * w[0] * own[i] for i in range(n)]
        for i, pull in enumerate(pulls):
            diag_rest[i] = diag_rest[i] + lam_f * pull[2]
        for r, i, curv in row_own:
            diag_rest[i] = diag_rest[i] + lam_g[r] * curv
        # −δ2 ∇²‖x_i − x_q‖ on [x_i, x_q] is −curv ⊗ [[1, −1], [−1, 1]]; keyed by q ≥ i. With
        # x_p = Σ_q w_q x_q and one-hot w (Σ w = 1, w_q w_q' = 0 for q ≠ q', w_q² = w_q), the
        # blocks are (i, i): −curv, (q, q): −w_q curv, (i, q): +w_q curv.
        pair_exact: dict[tuple[int, int], Any] = {}
        for r, i, mates, curv in row_pair:
            term = lam_g[r] * curv
            pair_exact[i, i] = pair_exact.get((i, i), 0) - term
            for q, wq in mates:
                weighted = term if len(mates) == 1 else wq * term
                key = (min(i, q), max(i, q))
                pair_exact[q, q] = pair_exact.get((q, q), 0) - weighted
                pair_exact[key] = pair_exact.get(key, 0) + weighted

        def exact_blocks() -> dict[tuple[int, int], Any]:
            """The exact Hessian's 2×2 blocks ``(i, q)``, ``q ≥ i``, of the velocities."""
            blocks: dict[tuple[int, int], Any] = {}
            for i in range(n):
                for q in range(i, n):
                    blk = lam_f * w[0] * gn[i, q] + pair_exact.get((i, q), 0)
                    if i == q:
                        blk = dt * dt * (blk + diag_rest[i]) + 2 * lam_f * w[1] * ca.SX.eye(2)
                    else:
                        blk = dt * dt * blk
                    blocks[i, q] = blk
            return blocks

        def clipped_blocks() -> dict[tuple[int, int], Any]:
            """Exact blocks with each diagonal block's eigenvalues clipped at ``margin``."""
            blocks = exact_blocks()
            for i in range(n):
                blocks[i, i] = _psd_clip(blocks[i, i], margin)
            return blocks

        def assemble(blocks: dict[tuple[int, int], Any], slack: float) -> tuple[Any, Any]:
            """(full symmetric, upper triangle) of the Hessian from its velocity blocks."""
            rows, cols, vals = [], [], []
            rows_t, cols_t, vals_t = [], [], []
            for (i, q), blk in blocks.items():
                for a in range(2):
                    for b in range(2):
                        r, c = 2 * i + a, 2 * q + b
                        v = blk[a, b]
                        if r <= c:
                            rows_t.append(r)
                            cols_t.append(c)
                            vals_t.append(v)
                        rows.append(r)
                        cols.append(c)
                        vals.append(v)
                        if i != q:
                            rows.append(c)
                            cols.append(r)
                            vals.append(v)
            if slack:
                for k in range(2 * n, nx):
                    for lst in (rows, cols, rows_t, cols_t):
                        lst.append(k)
                    vals.append(ca.SX(slack))
                    vals_t.append(ca.SX(slack))
            full = ca.SX.triplet(rows, cols, ca.vertcat(*vals), nx, nx)
            triu = ca.SX.triplet(rows_t, cols_t, ca.vertcat(*vals_t), nx, nx)
            return full, triu

        f_grad = ca.vertcat(*grad)
        self.functions = {
            "fg": ca.Function("nlp_fg", [x, p], [f, g_vec], ["x", "p"], ["f", "g"]),
            "grad_f": ca.Function("nlp_grad_f", [x, p], [f, f_grad], ["x", "p"], ["f", "grad_f_x"]),
            "jac_g": ca.Function("nlp_jac_g", [x, p], [g_vec, jac], ["x", "p"], ["g", "jac_g_x"]),
            "jac_fg": ca.Function(
                "nlp_jac_fg",
                [x, p],
                [f, f_grad, g_vec, jac],
                ["x", "p"],
                ["f", "grad_f_x", "g", "jac_g_x"],
            ),
        }
        hess_in = [x, p, lam_f, lam_g]
        hess_names = ["x", "p", "lam_f", "lam_g"]
        exact, exact_triu = assemble(exact_blocks(), 0.0)
        variants = {
            "hess_exact": exact,
            "hess_clip": assemble(clipped_blocks(), SLACK_CURVATURE)[0],
        }
        for name, hess in variants.items():
            self.functions[name] = ca.Function(
                "nlp_hess_l", hess_in, [hess], hess_names, ["hess_gamma_x_x"]
            )
        self.functions["hess_exact_triu"] = ca.Function(
            "nlp_hess_l", hess_in, [exact_triu], hess_names, ["triu_hess_gamma_x_x"]
        )
        self.nlp = {"x": x, "p": p, "f": f, "g": g_vec}
        #: size of the symbolic code (≈ 40 bytes of memory per instruction): the cache's weight
        self.n_instructions = sum(fn.n_instructions() for fn in self.functions.values())
        #: compile jobs of this problem's functions, by (method, SQP Hessian)
        self.jobs: dict[tuple[str, str], codegen.CompiledFunctions | None] = {}


#: Options of both solvers: nothing uses ``lam_p`` (∂L/∂p), which costs a reverse sweep over
#: the whole problem after each solve (≈ 0.4 ms at 20×20).
COMMON_OPTIONS: dict[str, Any] = {"print_time": False, "error_on_fail": False, "calc_lam_p": False}
#: IPOPT settings of the robust rungs (warm and cold start).
IPOPT_OPTIONS: dict[str, Any] = {
    "print_level": 0,
    "sb": "yes",
    "max_iter": 200,
    "tol": 1e-8,
    "acceptable_tol": 1e-5,
    "warm_start_init_point": "yes",
    "mu_init": 1e-3,
}
#: ``sqpmethod`` settings of the fast rung: exact Hessian with clipped diagonal blocks, a real
#: line search (10 backtracking steps), and few iterations before handing over to IPOPT.
#: Tolerances are absolute: 1e-6 m/s on the velocities is far below anything that matters,
#: and saves about half an iteration per solve against 1e-8.
SQP_OPTIONS: dict[str, Any] = {
    "max_iter": 25,
    "max_iter_ls": 10,
    "tol_pr": 1e-6,
    "tol_du": 1e-6,
    "min_step_size": 1e-12,
    "print_header": False,
    "print_iteration": False,
    "print_status": False,
}
#: qpOASES settings of the SQP's QPs.
QPOASES_OPTIONS: dict[str, Any] = {"printLevel": "none", "error_on_fail": False}
#: Smallest eigenvalue kept in each robot's 2×2 diagonal Hessian block by the SQP.
SQP_MARGIN = 1e-2
#: Per robot, sensing zones, comm zones and teammates of the SQP's reduced problem (see
#: :meth:`LeagueProblem.reduction`).
SLOTS = Slots(sensing=2, comm=1, mates=6)
#: The SQP reduces only problems with at least this many rows: below it qpOASES is cheap
#: anyway (a 5×5 league with 2 + 1 zones has 30), and the paper-sized leagues keep the exact
#: solver path their published numbers were made with.
REDUCE_FROM_ROWS = 100


def reduced_slots(structure: Structure, slots: Slots | None = SLOTS) -> Slots | None:
    """``slots`` capped at the structure's sizes; None when that reduces nothing."""
    if slots is None:
        return None
    n, nl, nk = structure.n_robots, structure.n_sensing_zones, structure.n_comm_zones
    comm = min(slots.comm, nk)
    capped = Slots(min(slots.sensing, nl), comm, min(slots.mates, n - 1) if comm else 0)
    if capped.sensing == nl and capped.comm == nk and (not nk or capped.mates == n - 1):
        return None
    return capped


class _BufferedCall:
    """One solver behind a single flat input and output vector, evaluated in place.

    CasADi's conversion of many NumPy arguments costs more than a small solve, so the solver is
    wrapped in an MX function of one vector ``[x0, p, lbx, ubx, lam_x0, lam_g0]`` returning
    ``[x, lam_x, lam_g, f]``, evaluated through :meth:`casadi.Function.buffer` on NumPy memory.
    """

    def __init__(self, solver: ca.Function, n_x: int, n_p: int, n_g: int):
        with _quiet_stdout():  # qpOASES prints a licence banner when its memory is set up
            self._setup(solver, n_x, n_p, n_g)

    def _setup(self, solver: ca.Function, n_x: int, n_p: int, n_g: int) -> None:
        self.solver = solver
        sizes = [n_x, n_p, n_x, n_x, n_x, n_g, n_g]
        z = ca.MX.sym("z", sum(sizes))
        x0, p, lbx, ubx, lam_x0, lam_g0, lbg = ca.vertsplit(z, np.cumsum([0, *sizes]).tolist())
        out = solver(
            x0=x0, p=p, lbx=lbx, ubx=ubx, lam_x0=lam_x0, lam_g0=lam_g0, lbg=lbg, ubg=ca.inf
        )
        flat = ca.vertcat(out["x"], out["lam_x"], out["lam_g"], out["f"])
        self.function = ca.Function(f"{solver.name()}_flat", [z], [flat])
        self.offsets = np.cumsum([0, *sizes])
        self.arg = np.zeros(int(self.offsets[-1]))
        self.res = np.zeros(2 * n_x + n_g + 1)
        self.n_x, self.n_g = n_x, n_g
        self.compiled = False
        buffer: Any  # the SWIG wrapper takes (index, buffer); its stub also lists a size
        buffer, self._evaluate = self.function.buffer()
        buffer.set_arg(0, self.arg.data)
        buffer.set_res(0, self.res.data)
        self._buffer = buffer
        self._first = True
        #: which of the solver's memories the wrapper uses (its stats live there)
        self.memory: int | None = None

    def __call__(self, *parts: np.ndarray) -> dict[str, np.ndarray]:
        o = self.offsets
        for k, part in enumerate(parts):
            self.arg[o[k] : o[k + 1]] = part
        if self._first:  # qpOASES prints a licence banner when its first QP is set up
            self._first = False
            with _quiet_stdout():
                self._evaluate()
        else:
            self._evaluate()
        n_x, n_g, r = self.n_x, self.n_g, self.res
        return {
            "x": r[:n_x].copy(),
            "lam_x": r[n_x : 2 * n_x].copy(),
            "lam_g": r[2 * n_x : 2 * n_x + n_g].copy(),
            "f": r[2 * n_x + n_g :].copy(),
        }

    def stats(self) -> dict[str, Any]:
        """Stats of the last evaluation; ``{"success": False, ...}`` when CasADi has none."""
        if self.memory is None:
            for memory in range(8):
                try:
                    self.solver.stats(memory)
                except RuntimeError:
                    continue
                self.memory = memory
                break
        try:
            return dict(self.solver.stats(self.memory or 0))
        except RuntimeError as err:  # sqpmethod may fail to report after a QP failure
            return {"success": False, "return_status": f"no stats ({err.__class__.__name__})"}


#: Symbolic problems (with their compile jobs), shared process-wide: building them is the
#: expensive, stateless part. Solvers are not shared: qpOASES keeps state from one solve to the
#: next, so a solver's results depend on its history, which must be the episode's own. The
#: least recently used problems beyond ``NLP_BUDGET`` instructions (≈ 160 MB) are forgotten.
NLP_BUDGET = 4_000_000
_NLPS: LruCache[tuple[Structure, float, Slots | None], LeagueNLP] = LruCache(
    NLP_BUDGET, weigh=lambda nlp: nlp.n_instructions
)


#: solvers created so far in this process (each holds native memory: see :func:`solver_builds`)
_BUILDS = {"solvers": 0}


def nlp_cache() -> LruCache[tuple[Structure, float, Slots | None], LeagueNLP]:
    """The process-wide cache of symbolic problems (its size, builds and evictions)."""
    return _NLPS


def solver_builds() -> int:
    """How many solvers (SQP or IPOPT, per problem) were created so far in this process."""
    return _BUILDS["solvers"]


def shared_nlp(
    structure: Structure, margin: float = SQP_MARGIN, slots: Slots | None = None
) -> LeagueNLP:
    """The process-wide :class:`LeagueNLP` of ``structure`` (built on first use)."""

    def build() -> LeagueNLP:
        log.debug("building league problem %s (slots %s)", structure, slots)
        return LeagueNLP(structure, margin, slots)

    return _NLPS.get((structure, margin, slots), build)


def wait_for_compilers() -> None:
    """Block until every compile job started in this process is done (for warm-ups)."""
    for nlp in _NLPS.values():
        for job in list(nlp.jobs.values()):
            if job is not None:
                job.wait()


@dataclass
class Reduction:
    """One step's reduced problem (:meth:`LeagueProblem.reduction`)."""

    #: the selection parameters (ssel, csel, msel), flattened column by column
    selection: np.ndarray
    #: each reduced row's row in the full problem, and whether the row is in use
    rows: np.ndarray
    active: np.ndarray
    #: each reduced slack's variable in the full problem (−1: an unused slot)
    variables: np.ndarray
    #: velocities first, the same in both problems
    n_u: int
    #: rows of the full problem
    n_constraints: int
    #: the full problem's bound multipliers of the slacks the reduced problem drops
    dropped_lam_x: np.ndarray

    def reduce(self, full: np.ndarray) -> np.ndarray:
        """A full problem's ``x`` or ``lam_x`` for the reduced problem."""
        used = self.variables >= 0
        slack = np.where(used, full[np.maximum(self.variables, 0)], 0.0)
        return np.concatenate([full[: self.n_u], slack])

    def reduce_rows(self, full: np.ndarray) -> np.ndarray:
        """A full problem's ``lam_g`` for the reduced problem."""
        return np.where(self.active, full[self.rows], 0.0)

    def expand(self, reduced: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The reduced problem's solution as the full problem's: dropped slacks are 0 at their
        bound, whose multiplier is then their cost (``∂L/∂ν = w + lam_x = 0``); dropped rows'
        multipliers are 0."""
        used = self.variables >= 0
        solution = {"f": reduced["f"]}
        for key, full in (("x", np.zeros(len(self.dropped_lam_x))), ("lam_x", None)):
            full = self.dropped_lam_x.copy() if full is None else full
            full[: self.n_u] = reduced[key][: self.n_u]
            full[self.variables[used]] = reduced[key][self.n_u :][used]
            solution[key] = full
        lam_g = np.zeros(self.n_constraints)
        lam_g[self.rows[self.active]] = reduced["lam_g"][self.active]
        solution["lam_g"] = lam_g
        return solution


class LeagueProblem:
    """A league NLP for one :class:`Structure`; solve with :meth:`solve`.

    ``solver`` is the default method of :meth:`solve`: ``"ipopt"`` (interior point with the
    exact Hessian) or ``"sqp"`` (CasADi's ``sqpmethod`` with qpOASES, see ``SQP_OPTIONS``).
    Solvers are created on first use, on compiled code when its library is in the cache
    (:mod:`~resilient_tracking.planning.codegen`; compiling starts in the background on first
    use otherwise). ``options`` may hold ``"ipopt"``, ``"sqp"`` and ``"qpoases"`` option dicts
    (merged over the defaults), ``"qpsol"`` (the SQP's QP solver plugin, default ``qpoases``;
    its options under its own name), ``"slots"`` (the :class:`Slots` of the SQP's reduced
    problem; default ``SLOTS`` for problems of ``REDUCE_FROM_ROWS`` rows or more, else None:
    never reduce), ``"sqp_hessian"`` (a key of :attr:`LeagueNLP.functions` without
    ``hess_``), ``"margin"`` and ``"codegen"`` (False: never use compiled code).

    The ``"sqp"`` method solves the reduced problem of :meth:`reduction` (only the zones and
    teammates that can bind this step) when there is one, else the full problem; its solution
    is returned in the full problem's layout either way, so warm starts pass between the two
    and the IPOPT rungs.
    """

    def __init__(self, structure: Structure, solver: str = "ipopt", options: dict | None = None):
        if solver not in METHODS:
            raise ValueError(f"solver: expected one of {METHODS}, got {solver!r}")
        self.structure = structure
        self.default_method = solver
        self.options = options or {}
        self.margin = float(self.options.get("margin", SQP_MARGIN))
        self.n_constraints = structure.n_constraints
        #: sizes of the SQP's reduced problem; None: the SQP always solves the full problem
        default = SLOTS if structure.n_constraints >= REDUCE_FROM_ROWS else None
        self.slots = reduced_slots(structure, self.options.get("slots", default))
        self._calls: dict[str, _BufferedCall] = {}
        self._nlps: dict[Slots | None, LeagueNLP] = {}
        self._lbg = np.zeros(self.n_constraints)
        self._ubg = np.full(self.n_constraints, np.inf)

    def solver(self, method: str | None = None) -> ca.Function:
        """The CasADi solver of ``method`` (built on first use)."""
        return self._call(method or self.default_method).solver

    def compiled(self, method: str | None = None) -> bool:
        """Whether ``method`` runs on compiled code."""
        return self._call(method or self.default_method).compiled

    def wait_for_compiler(self, methods: tuple[str, ...] = METHODS) -> None:
        """Block until the compiled code of ``methods`` is ready, and use it from now on.

        Without this, a solver keeps the code it was created with (compiled if the library was
        already in the cache): switching mid-episode would restart the solver's state at a
        moment set by the compiler's speed, which would break bit-for-bit reproducibility.
        """
        if "sqp" in methods and self.slots:
            methods = (*methods, "sqp_slots")
        for method in methods:
            job = self._job(method)
            if job is not None and job.wait() and not self._call(method).compiled:
                self._calls[method] = self._new_call(method, job)

    def _shared(self, slots: Slots | None) -> LeagueNLP:
        # held here once fetched: the shared cache may forget it while this problem lives
        if slots not in self._nlps:
            self._nlps[slots] = shared_nlp(self.structure, self.margin, slots)
        return self._nlps[slots]

    @property
    def nlp(self) -> LeagueNLP:
        """The full problem (built on first use: an SQP that always reduces never needs it)."""
        return self._shared(None)

    @property
    def n_params(self) -> int:
        return self.nlp.n_params

    @property
    def slot_nlp(self) -> LeagueNLP:
        """The SQP's reduced problem: each robot's comm rows for ``slots`` teammates only."""
        return self._shared(self.slots)

    @property
    def n_instructions(self) -> int:
        """Size of the symbolic problems built for this problem so far (its cache weight)."""
        return sum(nlp.n_instructions for nlp in self._nlps.values())

    def _nlp(self, method: str) -> LeagueNLP:
        return self.slot_nlp if method == "sqp_slots" else self.nlp

    def _functions(self, method: str) -> dict[str, ca.Function]:
        fn = self._nlp(method).functions
        if method == "ipopt":
            keys = {"grad_f": "grad_f", "jac_g": "jac_g", "hess_lag": "hess_exact_triu"}
        else:
            keys = {"fg": "fg", "jac_fg": "jac_fg", "hess_lag": "hess_" + self._sqp_hessian}
        return {role: fn[key] for role, key in keys.items()}

    @property
    def _sqp_hessian(self) -> str:
        return str(self.options.get("sqp_hessian", "clip"))

    def _job(self, method: str) -> codegen.CompiledFunctions | None:
        """The (shared) compile job of ``method``'s functions; None when codegen is off."""
        if not self.options.get("codegen", True):
            return None
        name = method
        if method == "sqp_slots" and self.slots:
            name = "sqp_slots{}s{}c{}m".format(*astuple(self.slots))
        nlp = self._nlp(method)
        key = (name, self._sqp_hessian)
        if key not in nlp.jobs:
            s = self.structure
            nlp.jobs[key] = codegen.compile_functions(self._functions(method), f"{s.label}_{name}")
        return nlp.jobs[key]

    def _call(self, method: str) -> _BufferedCall:
        if method not in self._calls:
            self._calls[method] = self._new_call(method, self._job(method))
        return self._calls[method]

    def _new_call(self, method: str, job: codegen.CompiledFunctions | None) -> _BufferedCall:
        functions = self._functions(method)
        compiled = job is not None and job.ready()
        if compiled and job is not None:
            try:
                functions = job.load()
                if "fg" in functions:
                    # the SQP's oracle: sqpmethod sets up (never calls: calc_lam_p is off)
                    # a gradient function of it, which needs derivatives to exist
                    functions = {**functions, "fg": job.external("fg", {"enable_fd": True})}
            except RuntimeError as err:  # a broken library: stay on the virtual machine
                log.warning("loading %s failed: %s", job.library, err)
                job.failed, compiled = True, False
        nlp = self._nlp(method)
        solver = self._build(method, functions, compiled)
        _BUILDS["solvers"] += 1
        call = _BufferedCall(solver, nlp.n_vars, nlp.n_params, nlp.n_constraints)
        call.compiled = compiled
        return call

    def _build(
        self, method: str, functions: dict[str, ca.Function], compiled: bool = False
    ) -> ca.Function:
        if method not in (*METHODS, "sqp_slots"):
            raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
        s = self.structure
        name = f"{s.label}_{method}"
        opts: dict[str, Any] = dict(COMMON_OPTIONS)
        # f and g symbolic: CasADi derives its own helpers (never called here) from them
        nlp: Any = self._nlp(method).nlp
        if method == "ipopt":
            opts.update(functions, ipopt={**IPOPT_OPTIONS, **self.options.get("ipopt", {})})
            return ca.nlpsol(name, "ipopt", nlp, opts)
        opts.update(SQP_OPTIONS)
        opts.update(self.options.get("sqp", {}))
        # f and g (line search, convergence test) on compiled code too when there is some, but
        # not for the reduced problem: for a compiled oracle sqpmethod sets up finite
        # differences over its ~2500 parameters (the slot selections), ≈ 35 MB per 20×20 solver
        functions = dict(functions)
        fg = functions.pop("fg")
        if compiled and method != "sqp_slots":
            nlp = fg
        qpsol = str(self.options.get("qpsol", "qpoases"))
        defaults = QPOASES_OPTIONS if qpsol == "qpoases" else {}
        opts.update(
            functions,
            qpsol=qpsol,
            qpsol_options={**defaults, **self.options.get(qpsol, {})},
        )
        with _quiet_stdout():  # qpOASES prints a licence banner when its memory is set up
            return ca.nlpsol(name, "sqpmethod", nlp, opts)

    # ------------------------------------------------------------------ packing

    def pack_params(self, q: ProblemInputs) -> np.ndarray:
        prior = np.stack(
            [q.prior_info[:, 0, 0], q.prior_info[:, 0, 1], q.prior_info[:, 1, 1]], axis=0
        )
        parts = [
            q.positions.T,
            q.sensing,
            q.targets.T,
            prior,
            q.weights,
            q.sensor,
            np.array([q.dt]),
            q.sensing_zones.reshape(-1, SENSING_COLUMNS).T,
            q.comm_zones.reshape(-1, COMM_COLUMNS).T,
        ]
        if self.structure.route:
            if q.route is None:
                raise ValueError("route: the route program needs route rows")
            parts.append(q.route.reshape(-1, ROUTE_COLUMNS).T)
        return np.concatenate([np.asarray(p, dtype=float).ravel(order="F") for p in parts])

    def bounds(self, q: ProblemInputs) -> tuple[np.ndarray, np.ndarray]:
        s = self.structure
        n_slack = s.n_robots * (s.n_sensing_zones + s.n_comm_zones)
        lower = np.concatenate([q.u_lower.ravel(), np.zeros(n_slack)])
        upper = np.concatenate([q.u_upper.ravel(), np.full(n_slack, np.inf)])
        return lower, upper

    def reduction(self, q: ProblemInputs) -> Reduction | None:
        """What the SQP's reduced problem (:class:`Slots`) keeps of this step's problem, or
        None when the full problem must be solved: no reduction for this structure, a robot
        needing more zones or teammates than it has slots, or a negative ``δ2``, ``w3`` or
        ``w4``.

        **Why the reduced problem has the same solutions.** The velocity bounds confine robot
        ``i``'s step to a disc of radius ``r_i = dt ‖(max(|lbu_ix|, |ubu_ix|), max(|lbu_iy|,
        |ubu_iy|))‖`` around ``x_i``; every SQP iterate stays within the bounds (each QP
        step does, and the line search moves along it), and so does the solution. Let
        ``D(x⁺, μ) = √(‖μ − x⁺‖² + ε²) ≥ √(max(‖μ − x_i‖ − r_i, 0)² + ε²)`` and, as
        ``‖â‖ < 1``, ``0 ≤ √(2 âᵀΣâ + ε_s) ≤ √(2 max(λ_max(Σ), 0) + ε_s)``, so ``β`` times
        it is at most ``max(β, 0) √(2 max(λ_max(Σ), 0) + ε_s)``. Together a lower bound
        ``H`` over the disc of a keep-out margin ``D − offset − β √(2 âᵀΣâ + ε_s)``.

        1. A sensing row ``(i, l)`` with ``H_il > tol`` holds with ``ν_il = 0`` for every
           control within the bounds. ``ν_il`` appears only there and in the objective with
           weight ``w3 ≥ 0``, so ``ν_il = 0`` at every solution (any solution with ``ν_il >
           0`` stays feasible and gets no worse with ``ν_il = 0``). Row and slack are dropped.
        2. A comm row ``(i, k, q)`` is ``h_ik(x_i⁺) − δ2 ρ(x_i⁺ − x_q⁺) + ξ_ik ≥ 0`` with
           ``ρ(v) = √(‖v‖² + ε²)`` increasing in ``‖v‖ ≤ d_iq + r_i + r_q`` (``d_iq = ‖x_i −
           x_q‖``). If ``H_ik − δ2 max_q ρ(d_iq + r_i + r_q) > tol`` every row of ``(i, k)``
           holds with ``ξ_ik = 0``: as in 1., the rows and ``ξ_ik`` are dropped.
        3. For the comm zones a robot keeps, its rows differ only in the teammate. Let ``q*``
           maximise ``d_iq − r_i − r_q``, a lower bound of ``‖x_i⁺ − x_q⁺‖``. A teammate with
           ``d_iq + r_i + r_q < d_iq* − r_i − r_q*`` is always nearer than ``q*``, so
           ``g_iqk ≥ g_iq*k`` (``δ2 ≥ 0``) and its row holds wherever row ``q*``'s does: it is
           dropped.

        So within the bounds the reduced and the full problem have the same feasible set up
        to dropped slacks that are zero at every solution: the same solutions, with the
        dropped rows' multipliers zero. ``tol`` (1e-9 m plus a relative 1e-9) covers rounding.
        A slot left unused gets a zero selection column (its slack costs nothing and is fixed
        at 0, its row is relaxed to ``−∞``): it changes nothing.
        """
        slots = self.slots
        if slots is None:
            return None
        if np.any(q.comm_zones[:, 5] < 0) or q.weights[2] < 0 or q.weights[3] < 0:
            return None
        s = self.structure
        n, nl, nk = s.n_robots, s.n_sensing_zones, s.n_comm_zones
        x = q.positions
        span = np.maximum(np.abs(q.u_lower), np.abs(q.u_upper))
        reach = q.dt * np.hypot(span[:, 0], span[:, 1])
        eps2 = PLAN_EPS**2

        def above(value: np.ndarray) -> np.ndarray:
            return np.asarray(value > 1e-9 * (1 + np.abs(value)))

        def keep_out_bound(z: np.ndarray, offset: np.ndarray, beta: np.ndarray) -> np.ndarray:
            """(robots, zones): ``H`` of each robot and zone row of ``z``."""
            gap = np.hypot(z[:, 0] - x[:, :1], z[:, 1] - x[:, 1:]) - reach[:, None]
            top = 0.5 * (z[:, 2] + z[:, 4]) + np.hypot(0.5 * (z[:, 2] - z[:, 4]), z[:, 3])
            spread = np.sqrt(2 * np.maximum(top, 0.0) + SPREAD_EPS)
            return np.sqrt(np.maximum(gap, 0.0) ** 2 + eps2) - offset - np.maximum(beta, 0) * spread

        z = q.sensing_zones.reshape(nl, SENSING_COLUMNS)
        need_s = ~above(keep_out_bound(z, z[:, 5], z[:, 6]))
        d = np.hypot(x[:, None, 0] - x[None, :, 0], x[:, None, 1] - x[None, :, 1])
        far = d + reach[:, None] + reach[None, :]
        near = d - reach[:, None] - reach[None, :]
        np.fill_diagonal(far, -np.inf)
        np.fill_diagonal(near, -np.inf)
        pair_top = np.sqrt(far.max(axis=1) ** 2 + eps2) if n > 1 else np.zeros(n)
        z = q.comm_zones.reshape(nk, COMM_COLUMNS)
        need_c = ~above(keep_out_bound(z, z[:, 7], z[:, 6]) - z[:, 5] * pair_top[:, None])
        best = near.max(axis=1)
        mates = far * (1 + 1e-9) + 1e-9 >= best[:, None]
        needs_mates = np.asarray(need_c.any(axis=1))
        mates &= needs_mates[:, None]
        if (
            need_s.sum(axis=1).max(initial=0) > slots.sensing
            or need_c.sum(axis=1).max(initial=0) > slots.comm
            or mates.sum(axis=1).max(initial=0) > slots.mates
        ):
            return None
        n_s, n_c, n_m = slots.sensing, slots.comm, slots.mates
        robot = np.arange(n)[:, None]
        full_rows = nl + nk * (n - 1)  # rows per robot in the full problem
        # the zones a robot needs fill its first slots, in zone order
        ssel = np.zeros((n, n_s, nl))
        slot_s = np.cumsum(need_s, axis=1) - 1
        i_s, l_s = np.nonzero(need_s)
        ssel[i_s, slot_s[i_s, l_s], l_s] = 1.0
        csel = np.zeros((n, n_c, nk))
        slot_c = np.cumsum(need_c, axis=1) - 1
        i_c, k_c = np.nonzero(need_c)
        csel[i_c, slot_c[i_c, k_c], k_c] = 1.0
        # teammates by their guaranteed distance, farthest first (a stable slot order);
        # unused teammate slots repeat the first, their rows relaxed
        msel = np.zeros((n, n_m, max(n - 1, 0)))
        order = np.argsort(np.where(mates, -near, np.inf), axis=1, kind="stable")[:, :n_m]
        in_use = np.asarray(np.arange(n_m)[None, :] < mates.sum(axis=1)[:, None])
        team = np.where(in_use, order, order[:, :1]) if n_m else order
        team = team - (team > robot)  # teammates numbered without robot i
        if n_m:
            msel[robot, np.arange(n_m)[None, :], team] = needs_mates[:, None]
        # each reduced row's full row, and whether it is in use
        zone_s = np.einsum("isl,l->is", ssel, np.arange(nl))
        zone_c = np.einsum("ick,k->ic", csel, np.arange(nk))
        used_s, used_c = np.asarray(ssel.any(axis=2)), np.asarray(csel.any(axis=2))
        rows_s = robot * full_rows + zone_s
        rows_c = robot[:, :, None] * full_rows + nl + zone_c[:, :, None] * (n - 1)
        rows_c = rows_c + team[:, None, :]
        active_c = used_c[:, :, None] & in_use[:, None, :]
        rows = np.concatenate([rows_s, rows_c.reshape(n, -1)], axis=1).astype(np.intp)
        active = np.concatenate([used_s, active_c.reshape(n, -1)], axis=1)
        # each reduced slack's variable in the full problem (−1: unused); ν of every robot,
        # then ξ of every robot, as in the reduced problem's x
        var_s = np.where(used_s, 2 * n + robot * nl + zone_s, -1)
        var_c = np.where(used_c, 2 * n + n * nl + robot * nk + zone_c, -1)
        dropped_lam_x = np.zeros(s.n_vars)
        dropped_lam_x[2 * n : 2 * n + n * nl] = -q.weights[2]
        dropped_lam_x[2 * n + n * nl :] = -q.weights[3]
        return Reduction(
            selection=np.concatenate([ssel.ravel(), csel.ravel(), msel.ravel()]),
            rows=rows.ravel(),
            active=active.ravel(),
            variables=np.concatenate([var_s.ravel(), var_c.ravel()]).astype(np.intp),
            n_u=2 * n,
            n_constraints=self.n_constraints,
            dropped_lam_x=dropped_lam_x,
        )

    def split(self, decision: np.ndarray) -> np.ndarray:
        """Velocities (n, 2) from a decision vector."""
        return np.asarray(decision[: 2 * self.structure.n_robots]).reshape(-1, 2)

    def solve(
        self,
        q: ProblemInputs,
        warm: dict[str, np.ndarray] | None = None,
        method: str | None = None,
    ) -> tuple[dict[str, np.ndarray], dict]:
        """Solve once; returns (solution with x, lam_x, lam_g, f; solver stats).

        ``warm`` (a previous solution) gives the primal and dual starting point; without it
        the solve starts from zero velocities and zero multipliers.
        """
        method = method or self.default_method
        lbx, ubx = self.bounds(q)
        if warm is not None:
            x0, lam_x0, lam_g0 = np.clip(warm["x"], lbx, ubx), warm["lam_x"], warm["lam_g"]
        else:
            x0 = np.clip(np.zeros(self.structure.n_vars), lbx, ubx)
            lam_x0, lam_g0 = np.zeros(self.structure.n_vars), np.zeros(self.n_constraints)
        reduction = self.reduction(q) if method == "sqp" else None
        if reduction is None:
            call = self._call(method)
            solution = call(x0, self.pack_params(q), lbx, ubx, lam_x0, lam_g0, self._lbg)
            return solution, call.stats()
        call = self._call("sqp_slots")
        r = reduction
        used = r.variables >= 0
        # an unused slot's slack is fixed at 0 (measured: cheaper for qpOASES than leaving
        # it free, which enlarges the null space it works in)
        lower = np.concatenate([lbx[: r.n_u], np.zeros(len(used))])
        upper = np.concatenate([ubx[: r.n_u], np.where(used, np.inf, 0.0)])
        reduced = call(
            np.clip(r.reduce(x0), lower, upper),
            np.concatenate([self.pack_params(q), r.selection]),
            lower,
            upper,
            r.reduce(lam_x0),
            r.reduce_rows(lam_g0),
            np.where(r.active, 0.0, -np.inf),
        )
        solution = r.expand(reduced)
        return solution, call.stats()


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silence what CasADi's plugins print for the duration.

    CasADi routes its plugins' messages through Python's ``sys.stdout``; C code may also write
    to file descriptor 1 directly, so both are redirected.
    """
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            _LIBC.fflush(None)
            saved = os.dup(1)
        except (OSError, ValueError):  # no file descriptor 1: nothing more to silence
            yield
            return
        try:
            with open(os.devnull, "w") as devnull:
                os.dup2(devnull.fileno(), 1)
                yield
        finally:
            _LIBC.fflush(None)  # drop what C stdio buffered while fd 1 was null
            os.dup2(saved, 1)
            os.close(saved)


_LIBC = ctypes.CDLL(None)
