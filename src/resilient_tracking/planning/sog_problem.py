"""The one-step NLP of the risk-aware SOG baseline (docs/model.md §7.2), a *reconstruction*
of Mayya et al., RA-L 2022, from its published description; its exact program was not available.

Per league robot ``i``: velocity ``u_i`` and a risk slack ``δ2i ≥ 0`` (when zones are known);
per target ``j`` a tracking slack ``δ1j ≥ 0``::

    min  w_e Σ_i ‖u_i‖² + w_t Σ_j δ1j + w_r Σ_i δ2i
    s.t. tr P⁺_j(x⁺) ≤ ρ1 + δ1j                      (tracking requirement)
         φ_i(x_i⁺)   ≤ ρ2 + δ2i                      (safety requirement, ρ2 = acceptable risk)
    with P⁺_j = (P⁻_j⁻¹ + O_j)⁻¹,  O_j = Σ_i s_i (1 − φᵒ_i(x_i⁺)) H_ijᵀ R_ij⁻¹ H_ij   (the SOG)

``s_i = 1`` when robot ``i``'s sensor works. A failure likelihood is the Gaussian zone hazard
of docs/model.md §2 accumulated over a window ``T`` at the zone *estimates*::

    φ(x) = 1 − exp(−c Σ_l pdf_N(μ̂_l, Σ̂_l)(x)),   c = κ f_act T

The safety requirement uses ``c = κ f_act T_risk``; the SOG weighs each sensor by its survival
over the planned step(s), ``φᵒ`` with ``c = κ f_act T_survival`` (see ``docs/paper-map.md``).

The problem is built once per :class:`SogStructure`; every number that changes between steps
(positions, estimates, zones, ρ, weights) is a parameter. :class:`SogPlanner` solves it with
the same ladder as the league planner: warm start → cold start → hold position.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from resilient_tracking.models.sensor import MeasurementModel, RangeBearingSensor
from resilient_tracking.planning.pieces import trace_of_inverse
from resilient_tracking.planning.planner import FaultHook, PlanResult, SolverLadder
from resilient_tracking.planning.solver_options import IPOPT_OPTIONS

log = logging.getLogger(__name__)

#: Columns of a zone row: mu(2), Σ⁻¹ xx/xy/yy, pdf normaliser 1/(2π√det Σ).
ZONE_COLUMNS = 6
#: Scalars: rho1, rho2, w_effort, w_track, w_risk, c of the requirement, c of the SOG.
SCALARS = 7


def zone_rows(means: list[np.ndarray], covs: list[np.ndarray]) -> np.ndarray:
    """Parameter rows ``(L, 6)`` of Gaussian zone estimates."""
    rows = []
    for mu, cov in zip(means, covs, strict=True):
        cov = _nondegenerate(np.asarray(cov, dtype=float))
        inv = np.linalg.inv(cov)
        norm = 1.0 / (2.0 * math.pi * math.sqrt(np.linalg.det(cov)))
        rows.append([mu[0], mu[1], inv[0, 0], inv[0, 1], inv[1, 1], norm])
    return np.array(rows, dtype=float).reshape(-1, ZONE_COLUMNS)


def _nondegenerate(cov: np.ndarray) -> np.ndarray:
    """``cov`` itself if its density is finite; else (det ≤ 0 or not finite, e.g. a collapsed
    estimate) ``cov`` with eigenvalues floored at ``max(1e-12 λmax, 1e-12)``, so the risk map is
    finite instead of a division by zero (a non-finite ``cov`` becomes the identity)."""
    det = float(np.linalg.det(cov)) if np.all(np.isfinite(cov)) else math.nan
    if det > 0 and math.isfinite(det) and math.isfinite(1.0 / math.sqrt(det)):
        return cov
    log.warning("degenerate zone covariance in the SOG risk map (det %g); repaired", det)
    if not np.all(np.isfinite(cov)):
        return np.eye(2)
    values, vectors = np.linalg.eigh((cov + cov.T) / 2)
    values = np.maximum(values, max(1e-12 * float(np.abs(values).max()), 1e-12))
    return np.asarray((vectors * values) @ vectors.T, dtype=float)


def failure_likelihood(positions: np.ndarray, zones: np.ndarray, scale: float) -> np.ndarray:
    """``φ(x) = 1 − exp(−c Σ_l pdf_l(x))`` at the rows of ``positions``; 0 with no zones."""
    x = np.atleast_2d(np.asarray(positions, dtype=float))
    density = np.zeros(len(x))
    for mx, my, ixx, ixy, iyy, norm in np.asarray(zones, dtype=float).reshape(-1, ZONE_COLUMNS):
        dx, dy = x[:, 0] - mx, x[:, 1] - my
        density += norm * np.exp(-0.5 * (ixx * dx * dx + 2 * ixy * dx * dy + iyy * dy * dy))
    return np.asarray(-np.expm1(-scale * density), dtype=float)


def _phi_expr(x: Any, zones: Any, scale: Any, n_zones: int) -> Any:
    density = 0
    for zl in range(n_zones):
        z = zones[:, zl]
        dx, dy = x[0] - z[0], x[1] - z[1]
        m2 = z[2] * dx * dx + 2 * z[3] * dx * dy + z[4] * dy * dy
        density = density + z[5] * ca.exp(-0.5 * m2)
    return 1 - ca.exp(-scale * density)


def likelihood_function(n_zones: int) -> ca.Function:
    """``(x (2,), zones (6, L), c) → φ``: the failure likelihood exactly as the NLP builds it."""
    x = ca.MX.sym("x", 2)
    zones = ca.MX.sym("zones", ZONE_COLUMNS, n_zones)
    scale = ca.MX.sym("c")
    phi = _phi_expr(x, zones, scale, n_zones)
    return ca.Function("sog_likelihood", [x, zones, scale], [phi])


def _sog_entries(
    xp: Any,
    weight: Any,
    target: Any,
    prior: Any,
    sensor: Any,
    model: type[MeasurementModel] = RangeBearingSensor,
) -> Any:
    """Entries (xx, xy, yy) of ``P⁻⁻¹ + Σ_i weight_i Hᵀ R⁻¹ H`` for one target."""
    a, b, c = prior[0], prior[1], prior[2]
    for i in range(xp.shape[1]):
        ixx, ixy, iyy = model.information_casadi(xp[:, i], target, sensor)
        a = a + weight[i] * ixx
        b = b + weight[i] * ixy
        c = c + weight[i] * iyy
    return a, b, c


def information_function(
    n_robots: int, n_targets: int, model: type[MeasurementModel] = RangeBearingSensor
) -> ca.Function:
    """``(x⁺ (2,n), weight (n,), targets (2,N), sensor (4,)) → O (3,N)``: the SOG entries
    ``Σ_i weight_i Hᵀ R⁻¹ H`` exactly as the NLP builds them (``weight = s (1 − φᵒ)``)."""
    xp = ca.MX.sym("x", 2, n_robots)
    weight = ca.MX.sym("w", n_robots)
    targets = ca.MX.sym("targets", 2, n_targets)
    sensor = ca.MX.sym("sensor", model.N_PARAMETERS)
    cols = [
        ca.vertcat(*_sog_entries(xp, weight, targets[:, j], ca.DM.zeros(3), sensor, model))
        for j in range(n_targets)
    ]
    return ca.Function("sog_information", [xp, weight, targets, sensor], [ca.horzcat(*cols)])


@dataclass(frozen=True)
class SogStructure:
    """What changes the symbolic problem: sizes only."""

    n_robots: int
    n_targets: int
    n_zones: int = 0
    #: the robots' measurement model
    sensor_model: type[MeasurementModel] = RangeBearingSensor

    @property
    def n_risk_slacks(self) -> int:
        return self.n_robots if self.n_zones else 0

    @property
    def n_vars(self) -> int:
        return 2 * self.n_robots + self.n_targets + self.n_risk_slacks


@dataclass
class SogInputs:
    """Numeric values for one solve."""

    positions: np.ndarray  # (n, 2)
    sensing: np.ndarray  # (n,) 1.0 if the robot's sensor works
    targets: np.ndarray  # (N, 2) predicted target positions at t+1
    prior_info: np.ndarray  # (N, 2, 2) predicted position-block information P⁻⁻¹
    sensor: np.ndarray  # the sensor model's parameters (MeasurementModel.parameters)
    dt: float
    u_lower: np.ndarray  # (n, 2)
    u_upper: np.ndarray  # (n, 2)
    zones: np.ndarray  # (L, 6) from zone_rows
    rho1: float
    rho2: float
    w_effort: float
    w_track: float
    w_risk: float
    risk_scale: float  # c = κ f_act T of the safety requirement
    survival_scale: float  # c = κ f_act T of the SOG's survival weights
    sensor_model: type[MeasurementModel] = RangeBearingSensor


class SogProblem:
    """A CasADi NLP for one :class:`SogStructure`; solve with :meth:`solve`."""

    def __init__(self, structure: SogStructure, solver: str = "ipopt"):
        self.structure = s = structure
        n, big_n, nz = s.n_robots, s.n_targets, s.n_zones
        u = ca.MX.sym("u", 2, n)
        d1 = ca.MX.sym("delta1", big_n)
        d2 = ca.MX.sym("delta2", s.n_risk_slacks)
        x0 = ca.MX.sym("x", 2, n)
        sense = ca.MX.sym("s", n)
        targets = ca.MX.sym("targets", 2, big_n)
        prior = ca.MX.sym("prior", 3, big_n)
        sensor = ca.MX.sym("sensor", s.sensor_model.N_PARAMETERS)
        dt = ca.MX.sym("dt")
        zones = ca.MX.sym("zones", ZONE_COLUMNS, nz)
        k = ca.MX.sym("scalars", SCALARS)
        rho1, rho2, w_e, w_t, w_r, c_risk, c_survival = (k[m] for m in range(SCALARS))
        self._param_parts = [x0, sense, targets, prior, sensor, dt, zones, k]

        xp = x0 + u * dt
        phi = [_phi_expr(xp[:, i], zones, c_risk, nz) for i in range(n)]
        survive = ca.vertcat(
            *[sense[i] * (1 - _phi_expr(xp[:, i], zones, c_survival, nz)) for i in range(n)]
        )
        g = []
        for j in range(big_n):
            a, b, c = _sog_entries(
                xp, survive, targets[:, j], prior[:, j], sensor, s.sensor_model
            )
            trace = trace_of_inverse(a, b, c)
            g.append(rho1 + d1[j] - trace)
        if nz:
            g += [rho2 + d2[i] - phi[i] for i in range(n)]
        cost = w_e * ca.sumsqr(u) + w_t * ca.sum1(d1)
        if nz:
            cost += w_r * ca.sum1(d2)
        self.n_constraints = len(g)
        nlp = {
            "x": ca.veccat(u, d1, d2),
            "p": ca.veccat(*self._param_parts),
            "f": cost,
            "g": ca.vertcat(*g),
        }
        opts: dict[str, Any] = {"print_time": False, "error_on_fail": False}
        if solver == "ipopt":
            opts["ipopt"] = dict(IPOPT_OPTIONS)  # the league planner's robust rungs' settings
        self.solver = ca.nlpsol(f"sog_{n}x{big_n}_{nz}z", solver, nlp, opts)

    def pack_params(self, q: SogInputs) -> np.ndarray:
        prior = np.stack(
            [q.prior_info[:, 0, 0], q.prior_info[:, 0, 1], q.prior_info[:, 1, 1]], axis=0
        )
        scalars = [
            q.rho1,
            q.rho2,
            q.w_effort,
            q.w_track,
            q.w_risk,
            q.risk_scale,
            q.survival_scale,
        ]
        parts = [
            q.positions.T,
            q.sensing,
            q.targets.T,
            prior,
            q.sensor,
            np.array([q.dt]),
            q.zones.reshape(-1, ZONE_COLUMNS).T,
            np.array(scalars),
        ]
        return np.concatenate([np.asarray(p, dtype=float).ravel(order="F") for p in parts])

    def bounds(self, q: SogInputs) -> tuple[np.ndarray, np.ndarray]:
        n_slack = self.structure.n_targets + self.structure.n_risk_slacks
        lower = np.concatenate([q.u_lower.ravel(), np.zeros(n_slack)])
        upper = np.concatenate([q.u_upper.ravel(), np.full(n_slack, np.inf)])
        return lower, upper

    def split(self, decision: np.ndarray) -> np.ndarray:
        """Velocities (n, 2) from a decision vector."""
        return np.asarray(decision[: 2 * self.structure.n_robots]).reshape(-1, 2)

    def solve(
        self, q: SogInputs, warm: dict[str, np.ndarray] | None = None, method: str | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Solve once with IPOPT (``method`` is accepted for the ladder; only IPOPT is built);
        returns (solution with x, lam_x, lam_g, f; solver stats)."""
        lbx, ubx = self.bounds(q)
        args: dict[str, Any] = {
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


class SogPlanner(SolverLadder):
    """The planner's never-crashing ladder (IPOPT warm → cold → hold position) over
    :class:`SogProblem`; one problem per structure, a warm start per league membership."""

    def __init__(self, fault_hook: FaultHook | None = None):
        super().__init__("ipopt", fault_hook)

    def build(self, structure: SogStructure) -> SogProblem:
        return SogProblem(structure)

    def plan_sog(self, members: tuple[int, ...], q: SogInputs) -> PlanResult:
        structure = SogStructure(
            len(q.positions), len(q.targets), len(q.zones), sensor_model=q.sensor_model
        )
        return self.plan(structure, members, q)
