"""The one-step league NLP (SPEC §4, paper eq. 7), built once per structure, solved many times.

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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

#: Distance regularisation (m) in the planner's information model and in â.
PLAN_EPS = 0.05
#: Keeps √(2 âᵀΣâ) differentiable where â vanishes (a robot exactly on a zone's mean).
SPREAD_EPS = 1e-9
#: Columns of a sensing-zone row: mu(2), sigma xx/xy/yy, r_safe, beta1.
SENSING_COLUMNS = 7
#: Columns of a comm-zone row: mu(2), sigma xx/xy/yy, delta2, beta2, clearance.
COMM_COLUMNS = 8


@dataclass(frozen=True)
class Structure:
    """What changes the symbolic problem: sizes only."""

    n_robots: int
    n_targets: int
    n_sensing_zones: int = 0
    n_comm_zones: int = 0

    @property
    def n_vars(self) -> int:
        return self.n_robots * (2 + self.n_sensing_zones + self.n_comm_zones)


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


def _unit_and_norm(v: ca.MX) -> tuple[ca.MX, ca.MX]:
    norm = ca.sqrt(ca.sumsqr(v) + PLAN_EPS**2)
    return v / norm, norm


def _quad(a: ca.MX, sxx: ca.MX, sxy: ca.MX, syy: ca.MX) -> ca.MX:
    return a[0] * a[0] * sxx + 2 * a[0] * a[1] * sxy + a[1] * a[1] * syy


def measurement_information(x: ca.MX, p: ca.MX, sensor: ca.MX) -> tuple[ca.MX, ca.MX, ca.MX]:
    """Entries (xx, xy, yy) of ``Hᵀ R⁻¹ H`` for a range-bearing sensor at ``x`` seeing ``p``."""
    delta = p - x
    d2 = ca.sumsqr(delta) + PLAN_EPS**2
    d = ca.sqrt(d2)
    info_r = sensor[0] * ca.exp(-sensor[1] * d) / d2  # range row is δᵀ/d
    info_b = sensor[2] * ca.exp(-sensor[3] * d) / (d2 * d2)  # bearing row is [−δy, δx]/d²
    dx, dy = delta[0], delta[1]
    return (
        info_r * dx * dx + info_b * dy * dy,
        (info_r - info_b) * dx * dy,
        info_r * dy * dy + info_b * dx * dx,
    )


class LeagueProblem:
    """A CasADi NLP for one :class:`Structure`; solve with :meth:`solve`."""

    def __init__(self, structure: Structure, solver: str = "ipopt", options: dict | None = None):
        self.structure = s = structure
        n, big_n, nl, nk = s.n_robots, s.n_targets, s.n_sensing_zones, s.n_comm_zones
        u = ca.MX.sym("u", 2, n)
        nu = ca.MX.sym("nu", nl, n)
        xi = ca.MX.sym("xi", nk, n)
        x0 = ca.MX.sym("x", 2, n)
        sense = ca.MX.sym("s", n)
        targets = ca.MX.sym("targets", 2, big_n)
        prior = ca.MX.sym("prior", 3, big_n)
        w = ca.MX.sym("w", 4)
        sensor = ca.MX.sym("sensor", 4)
        dt = ca.MX.sym("dt")
        szones = ca.MX.sym("szones", SENSING_COLUMNS, nl)
        czones = ca.MX.sym("czones", COMM_COLUMNS, nk)
        self._param_parts = [x0, sense, targets, prior, w, sensor, dt, szones, czones]

        xp = x0 + u * dt
        track = ca.MX(0)
        for j in range(big_n):
            a, b, c = prior[0, j], prior[1, j], prior[2, j]
            for i in range(n):
                ixx, ixy, iyy = measurement_information(xp[:, i], targets[:, j], sensor)
                a = a + sense[i] * ixx
                b = b + sense[i] * ixy
                c = c + sense[i] * iyy
            track = track + (a + c) / (a * c - b * b)  # tr of the 2×2 inverse
        cost = w[0] * track + w[1] * ca.sumsqr(u)
        if nl:
            cost += w[2] * ca.sum1(ca.sum2(nu))
        if nk:
            cost += w[3] * ca.sum1(ca.sum2(xi))

        g = []
        for i in range(n):
            for zl in range(nl):
                z = szones[:, zl]
                ahat, dist = _unit_and_norm(z[0:2] - xp[:, i])
                spread = ca.sqrt(2 * _quad(ahat, z[2], z[3], z[4]) + SPREAD_EPS)
                g.append(dist - z[5] + nu[zl, i] - z[6] * spread)
            for zk in range(nk):
                z = czones[:, zk]
                ahat, dist = _unit_and_norm(z[0:2] - xp[:, i])
                spread = ca.sqrt(2 * _quad(ahat, z[2], z[3], z[4]) + SPREAD_EPS)
                for j in range(n):
                    if j != i:
                        pair = ca.sqrt(ca.sumsqr(xp[:, i] - xp[:, j]) + PLAN_EPS**2)
                        g.append(dist - z[5] * pair - z[7] + xi[zk, i] - z[6] * spread)
        self.n_constraints = len(g)
        decision = ca.veccat(u, nu, xi)
        params = ca.veccat(*self._param_parts)
        nlp = {"x": decision, "p": params, "f": cost, "g": ca.vertcat(*g) if g else ca.MX(0, 1)}
        opts: dict[str, Any] = {"print_time": False, "error_on_fail": False}
        if solver == "ipopt":
            opts["ipopt"] = {
                "print_level": 0,
                "sb": "yes",
                "max_iter": 200,
                "tol": 1e-8,
                "acceptable_tol": 1e-5,
                "warm_start_init_point": "yes",
                "mu_init": 1e-3,
            }
        opts.update(options or {})
        self.solver = ca.nlpsol(f"league_{n}x{big_n}_{nl}s{nk}c", solver, nlp, opts)
        self.n_params = int(params.shape[0])

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
        return np.concatenate([np.asarray(p, dtype=float).ravel(order="F") for p in parts])

    def bounds(self, q: ProblemInputs) -> tuple[np.ndarray, np.ndarray]:
        s = self.structure
        n_slack = s.n_robots * (s.n_sensing_zones + s.n_comm_zones)
        lower = np.concatenate([q.u_lower.ravel(), np.zeros(n_slack)])
        upper = np.concatenate([q.u_upper.ravel(), np.full(n_slack, np.inf)])
        return lower, upper

    def split(self, decision: np.ndarray) -> np.ndarray:
        """Velocities (n, 2) from a decision vector."""
        return np.asarray(decision[: 2 * self.structure.n_robots]).reshape(-1, 2)

    def solve(
        self,
        q: ProblemInputs,
        warm: dict[str, np.ndarray] | None = None,
    ) -> tuple[dict[str, np.ndarray], dict]:
        """Solve once; returns (solution with x, lam_x, lam_g, f; solver stats)."""
        lbx, ubx = self.bounds(q)
        args = {
            "p": self.pack_params(q),
            "lbx": lbx,
            "ubx": ubx,
            "lbg": np.zeros(self.n_constraints),
            "ubg": np.full(self.n_constraints, np.inf),
        }
        if warm is not None:
            args["x0"] = np.clip(warm["x"], lbx, ubx)
            args["lam_x0"] = warm["lam_x"]
            args["lam_g0"] = warm["lam_g"]
        else:
            args["x0"] = np.clip(np.zeros(self.structure.n_vars), lbx, ubx)
        out = self.solver(**args)
        solution = {k: np.asarray(out[k]).ravel() for k in ("x", "lam_x", "lam_g", "f")}
        return solution, dict(self.solver.stats())
