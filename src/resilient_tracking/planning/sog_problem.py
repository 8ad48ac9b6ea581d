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

The problem is built once per :class:`SogStructure` and shared process-wide; every number that
changes between steps (positions, estimates, zones, ρ, weights) is a parameter. It runs on the
league problem's fast path (:mod:`~.sog_nlp`: SX, compiled derivatives) and :class:`SogPlanner`
solves it with the league planner's ladder: SQP from the last solution → IPOPT warm → IPOPT
cold → hold position.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.models.sensor import MeasurementModel
from resilient_tracking.planning.compiled_problem import CompiledProblem
from resilient_tracking.planning.planner import FaultHook, PlanResult, SolverLadder
from resilient_tracking.planning.sog_nlp import (
    ZONE_COLUMNS,
    SogNLP,
    phi_expr,
    shared_sog_nlp,
)
from resilient_tracking.planning.solver_options import METHODS, ProblemOptions

log = logging.getLogger(__name__)


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


def likelihood_function(n_zones: int) -> ca.Function:
    """``(x (2,), zones (6, L), c) → φ``: the failure likelihood exactly as the NLP builds it."""
    x = ca.MX.sym("x", 2)
    zones = ca.MX.sym("zones", ZONE_COLUMNS, n_zones)
    scale = ca.MX.sym("c")
    phi = phi_expr(x, zones, scale, n_zones)
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
        """Risk slacks ``δ2i``: one per robot when zones are known, else none."""
        return self.n_robots if self.n_zones else 0

    @property
    def n_vars(self) -> int:
        """Decision variables: velocities ``u_i`` (2 per robot), tracking slacks ``δ1j`` (one per
        target), then the risk slacks."""
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


class SogProblem(CompiledProblem):
    """The SOG program of one :class:`SogStructure` ready to solve with :meth:`solve`: the
    shared symbolic problem (:class:`~.sog_nlp.SogNLP`) with this planner's own solvers
    (qpOASES keeps state between solves, so solvers are never shared between episodes)."""

    def __init__(self, structure: SogStructure, options: ProblemOptions | None = None):
        super().__init__(options or ProblemOptions(), "ipopt")
        self.structure = structure
        self.nlp = shared_sog_nlp(structure)
        self.n_constraints = self.nlp.n_constraints
        self._lbg = np.zeros(self.n_constraints)

    def symbolic(self, method: str) -> SogNLP:
        """The one symbolic problem every method solves."""
        return self.nlp

    def roles(self, method: str) -> dict[str, ca.Function]:
        """The functions of :meth:`~.sog_nlp.SogNLP.roles`."""
        if method not in METHODS:
            raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
        return self.nlp.roles(method)

    def compile_label(self, method: str) -> tuple[str, str, None]:
        """Jobs by method, labelled by the sizes and the sensor model (no index key)."""
        s = self.structure
        label = f"sog_{s.n_robots}x{s.n_targets}_{s.n_zones}z_{s.sensor_model.__name__}_{method}"
        return method, label, None

    def _build(self, method: str, functions: dict[str, ca.Function], compiled: bool) -> Any:
        s = self.structure
        name = f"sog_{s.n_robots}x{s.n_targets}_{s.n_zones}z_{method}"
        return self._nlpsol(name, method, self.nlp.nlp, functions)

    def pack_params(self, q: SogInputs) -> np.ndarray:
        """The parameter vector of one solve, in the order :class:`SogNLP` declares it: positions,
        sensing flags, targets, prior information, sensor numbers, ``dt``, zone rows, then
        ``ρ1, ρ2``, the weights and the hazard scales."""
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
        """Lower and upper bounds of the decision vector: the velocity bounds, then slacks ``≥
        0``."""
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
        """Solve once with ``method`` (``"sqp"`` or ``"ipopt"``, default IPOPT) from ``warm``
        (a previous solution: primal and dual start) or from zero; returns (solution with x,
        lam_x, lam_g, f; solver stats)."""
        lbx, ubx = self.bounds(q)
        x0, lam_x0, lam_g0 = self.start_point(warm, lbx, ubx, self.n_constraints)
        call = self._call(method or self.default_method)
        solution = call(x0, self.pack_params(q), lbx, ubx, lam_x0, lam_g0, self._lbg)
        return solution, call.stats()


class SogPlanner(SolverLadder):
    """The league planner's never-crashing ladder over :class:`SogProblem` (SQP → IPOPT warm
    → IPOPT cold → hold position; ``solver="ipopt"`` starts at IPOPT); one problem per
    structure, a warm start per league membership."""

    def __init__(
        self,
        fault_hook: FaultHook | None = None,
        solver: str = "ladder",
        options: ProblemOptions | dict[str, Any] | None = None,
    ):
        super().__init__(solver, fault_hook)
        self.options = ProblemOptions.of(options)

    def build(self, structure: SogStructure) -> SogProblem:
        """The SOG problem of ``structure`` with this planner's options."""
        return SogProblem(structure, self.options)

    def plan_sog(self, members: tuple[int, ...], q: SogInputs) -> PlanResult:
        """Controls ``(n, 2)`` for one league from inputs ``q``, through the ladder (its structure
        read from ``q``'s sizes)."""
        structure = SogStructure(
            len(q.positions), len(q.targets), len(q.zones), sensor_model=q.sensor_model
        )
        return self.plan(structure, members, q)
