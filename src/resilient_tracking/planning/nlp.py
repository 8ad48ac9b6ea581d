"""The one-step league NLP (docs/model.md §5, paper eqs. 6 and 9) as CasADi functions with
structured first and second derivatives; built once per structure, solved many times.

Decision variables per league robot ``i``: velocity ``u_i``, slacks ``ν_il ≥ 0`` per known
sensing zone and ``ξ_ik ≥ 0`` per known comm zone::

    min  w1 Σ_j tr P⁺_j(x⁺) + Σ_i [w2 ‖u_i‖² + w3 Σ_l ν_il + w4 Σ_k ξ_ik]
    s.t. ‖x_i⁺ − μ_S‖ − r_safe + ν_il ≥ β1 √(2 âᵀ Σ_S â)                  (eq. 7c)
         ‖x_i⁺ − μ_C‖ − δ2 ‖x_i⁺ − x_j⁺‖ − c_k + ξ_ik ≥ β2 √(2 âᵀ Σ_C â)  ∀ j ≠ i  (eq. 7d)

with ``x_i⁺ = x_i + u_i dt`` and the keep-out margins of :mod:`~.margins`. ``P⁺_j`` is the
position block of the one-step EKF posterior: the predicted position information plus
``s_i Hᵀ R⁻¹ H`` of every robot (``s_i = 1`` when it can sense), from the sensor model.
The velocity bounds and the workspace become simple bounds on ``u``.

Everything that changes from step to step is a parameter (:mod:`~.layout`), so one cached
problem serves every step of a given structure.

**Derivatives by structure.** The objective and constraints are sums of small pieces
(:mod:`~.pieces`) whose derivatives are assembled instead of differentiating the whole graph;
this roughly halves the Hessian's cost at 20 robots. With ``A_j = prior_j + Σ_i s_i m_ij`` and
``F_j = tr A_j⁻¹`` as a function of ``(a, b, c)``, the tracking term's Hessian is::

    ∂²F_j/∂x_i∂x_k = s_i s_k M_ijᵀ ∇²F_j M_kj + δ_ik s_i Σ_m ∂F_j/∂m · ∇²m_ij

(``M_ij`` the 3×2 Jacobian of ``m_ij``). The first part is positive semidefinite (``tr A⁻¹`` is
convex in ``A``); the 2×2 diagonal blocks carry the rest, which is indefinite near a target
(the bearing information peaks on a ring of radius ``PLAN_EPS`` around it), together with the
keep-out curvature. The SQP therefore uses the exact Hessian with each robot's 2×2 diagonal
block's eigenvalues clipped from below (closed form), IPOPT the exact Hessian.

The constructor is a sequence of named steps: variables, parameters, the tracking term, the
objective, the constraint rows, the Hessians, the functions. A new objective term is a new
step that adds its value, gradient and 2×2 Hessian blocks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi as ca

from resilient_tracking.planning.compile_jobs import CompiledFunctions
from resilient_tracking.planning.hessian import assemble, psd_clip, sym2
from resilient_tracking.planning.layout import (
    CommRow,
    ParameterLayout,
    SensingRow,
    Slots,
    Structure,
    VariableLayout,
    Weight,
)
from resilient_tracking.planning.pieces import piece_functions

#: Curvature put on the slack variables in the SQP's Hessian (they enter linearly).
SLACK_CURVATURE = 1e-6


@dataclass
class TrackingTerm:
    """``Σ_j tr P⁺_j`` with its derivatives w.r.t. each ``x_i⁺``."""

    value: Any
    #: ∇ w.r.t. x_i⁺, per robot
    grad: list[Any]
    #: Σ_j s_i s_q M_ijᵀ ∇²F_j M_qj for q ≥ i (PSD as a whole)
    gauss_newton: dict[tuple[int, int], Any]
    #: Σ_j s_i Σ_m ∂F/∂m ∇²m_ij, per robot
    own: list[Any]


@dataclass
class ConstraintRows:
    """The rows ``g ≥ 0`` with their Jacobian (triplets) and curvature pieces (w.r.t. x⁺)."""

    g: list[Any] = field(default_factory=list)
    jrows: list[int] = field(default_factory=list)
    jcols: list[int] = field(default_factory=list)
    jvals: list[Any] = field(default_factory=list)
    #: (row, robot, 2×2 curvature)
    own: list[tuple[int, int, Any]] = field(default_factory=list)
    #: (row, i, [(q, weight)], δ2 · ∇²‖x_i − x_p‖) with x_p = Σ_q weight x_q (one-hot)
    pair: list[tuple[int, int, list[tuple[int, Any]], Any]] = field(default_factory=list)


class LeagueNLP:
    """Symbolic NLP of one :class:`Structure` with structured first and second derivatives.

    Functions (all SX, inputs ``x, p`` and for Hessians ``lam_f, lam_g``):
    ``fg`` → (f, g); ``grad_f`` → (f, ∇f); ``jac_g`` → (g, ∂g/∂x); ``jac_fg`` → (f, ∇f, g, ∂g/∂x);
    ``hess_exact`` → the exact Hessian of the Lagrangian ``lam_f f + lam_gᵀ g`` (full symmetric),
    ``hess_exact_triu`` its upper triangle; ``hess_clip`` → the SQP's Hessian: exact, each
    robot's 2×2 diagonal block clipped to eigenvalues ≥ ``margin``, slacks given a tiny
    curvature (see the module docstring).

    With ``slots`` it is the SQP's reduced problem (:mod:`~.reduction`): a fixed number of
    zone and teammate rows per robot, chosen by one-hot selection parameters.
    """

    def __init__(self, structure: Structure, margin: float = 1e-2, slots: Slots | None = None):
        self.structure = s = structure
        self.margin = margin
        self.slots = slots
        # slack variables per robot: one per zone, or one per slot of the reduced problem
        n_nu, n_xi = (slots.sensing, slots.comm) if slots else (s.n_sensing_zones, s.n_comm_zones)
        self.variables = VariableLayout(s.n_robots, n_nu, n_xi)
        self._declare_variables()
        self._declare_parameters()
        self.pieces = piece_functions(s.sensor_model, s.standoff)
        #: planned positions x_i⁺ = x_i + u_i dt
        self.xps = [self.xp[:, i] for i in range(s.n_robots)]
        track = self._tracking_term()
        self.pulls = self._route_pulls()
        f, grad = self._objective(track)
        rows = self._constraints()
        self._build_functions(f, grad, track, rows)

    # ------------------------------------------------------------------ steps

    def _declare_variables(self) -> None:
        n, v = self.structure.n_robots, self.variables
        self.u = ca.SX.sym("u", 2, n)
        self.nu = ca.SX.sym("nu", v.n_nu, n)
        self.xi = ca.SX.sym("xi", v.n_xi, n)
        self.x = ca.veccat(self.u, self.nu, self.xi)
        self.n_vars = int(self.x.shape[0])

    def _declare_parameters(self) -> None:
        self.params = ParameterLayout(self.structure, self.slots).symbols()
        self.p = ca.veccat(*self.params.values())
        self.n_params = int(self.p.shape[0])
        self.xp = self.params["positions"] + self.u * self.params["dt"]

    def _tracking_term(self) -> TrackingTerm:
        """``Σ_j tr P⁺_j``, its gradient and the two parts of its Hessian (w.r.t. x⁺)."""
        n, big_n = self.structure.n_robots, self.structure.n_targets
        info, trace = self.pieces["info"], self.pieces["trace"]
        sense, targets = self.params["sensing"], self.params["targets"]
        prior, sensor = self.params["prior_info"], self.params["sensor"]
        value = ca.SX(0)
        grad = [ca.SX.zeros(2) for _ in range(n)]
        gn: dict[tuple[int, int], Any] = {}
        own = [ca.SX.zeros(2, 2) for _ in range(n)]
        for j in range(big_n):
            parts = [info(self.xps[i], targets[:, j], sensor) for i in range(n)]
            abc = prior[:, j]
            for i in range(n):
                abc = abc + sense[i] * parts[i][0]
            f_j, g_j, h_j = trace(abc)
            value = value + f_j
            jacs = [sense[i] * parts[i][1] for i in range(n)]  # 3 × 2 each
            for i in range(n):
                left = ca.mtimes(jacs[i].T, h_j)  # 2 × 3
                for q in range(i, n):
                    gn[i, q] = gn.get((i, q), 0) + ca.mtimes(left, jacs[q])
                grad[i] = grad[i] + ca.mtimes(jacs[i].T, g_j)
                own[i] = own[i] + sense[i] * sym2(ca.mtimes(parts[i][2].T, g_j))
        return TrackingTerm(value, grad, gn, own)

    def _objective(self, track: TrackingTerm) -> tuple[Any, list[Any]]:
        """``f`` (eq. 6) and its gradient w.r.t. x: tracking, effort, then the slacks."""
        n, v = self.structure.n_robots, self.variables
        w, dt, u = self.params["weights"], self.params["dt"], self.u
        f = w[Weight.TRACKING] * track.value + w[Weight.EFFORT] * ca.sumsqr(u)
        for pull in self.pulls:
            f = f + pull[0]
        grad = [ca.SX(0)] * self.n_vars
        for i in range(n):
            gi = w[Weight.TRACKING] * dt * track.grad[i] + 2 * w[Weight.EFFORT] * u[:, i]
            if self.pulls:
                gi = gi + dt * self.pulls[i][1]
            grad[v.u(i)], grad[v.u(i) + 1] = gi[0], gi[1]
        return self._slack_costs(f, grad)

    def _route_pulls(self) -> list[tuple[Any, Any, Any]]:
        """The route program's cost-to-go per robot, with its gradient and curvature w.r.t.
        ``x_i⁺`` (none in the one-step program)."""
        if not self.structure.route:
            return []
        rows = self.params["route"]
        return [self.pieces["route"](self.xps[i], rows[:, i]) for i in range(len(self.xps))]

    def _slack_costs(self, f: Any, grad: list[Any]) -> tuple[Any, list[Any]]:
        """``w3 Σ ν + w4 Σ ξ``: with slots, a slot's slack costs only if the slot is in use
        (its selection column sums to 1)."""
        s, v, w = self.structure, self.variables, self.params["weights"]
        w_nu, w_xi = w[Weight.SENSING_SLACK], w[Weight.COMM_SLACK]
        n, n_nu, n_xi = s.n_robots, v.n_nu, v.n_xi
        if self.slots:
            ssel, csel = self.params["ssel"], self.params["csel"]
            nu_cost = [ca.sum1(ssel[:, c]) for c in range(n * n_nu)]
            xi_cost = [ca.sum1(csel[:, c]) for c in range(n * n_xi)]
            f += w_nu * ca.dot(ca.vertcat(*nu_cost), ca.vec(self.nu)) if n_nu else 0
            f += w_xi * ca.dot(ca.vertcat(*xi_cost), ca.vec(self.xi)) if n_xi else 0
            for i in range(n):
                for zl in range(n_nu):
                    grad[v.nu(i, zl)] = w_nu * nu_cost[i * n_nu + zl]
                for zk in range(n_xi):
                    grad[v.xi(i, zk)] = w_xi * xi_cost[i * n_xi + zk]
        else:
            if s.n_sensing_zones:
                f += w_nu * ca.sum1(ca.sum2(self.nu))
            if s.n_comm_zones:
                f += w_xi * ca.sum1(ca.sum2(self.xi))
            for i in range(n):
                for zl in range(s.n_sensing_zones):
                    grad[v.nu(i, zl)] = w_nu
                for zk in range(s.n_comm_zones):
                    grad[v.xi(i, zk)] = w_xi
        return f, grad

    def _sensing_row(self, rows: ConstraintRows, i: int, z: Any, slack: int) -> None:
        """Eq. 7c for robot ``i`` and sensing-zone row ``z``."""
        dt, v = self.params["dt"], self.variables
        h, dh, ddh = self.pieces["keep_out"](
            self.xps[i], z[SensingRow.GAUSSIAN], z[SensingRow.R_SAFE], z[SensingRow.BETA]
        )
        r = len(rows.g)
        rows.g.append(h + self.x[slack])
        rows.jrows.extend([r, r, r])
        rows.jcols.extend([v.u(i), v.u(i) + 1, slack])
        rows.jvals.extend([dt * dh[0], dt * dh[1], ca.SX(1)])
        rows.own.append((r, i, ddh))

    def _linked_delta2(self, delta2: Any, i: int, q: int) -> Any:
        """``δ2`` of robot ``i``'s eq. 7d row with teammate ``q``: the zone's in the paper's
        program; the route program's ``unlinked`` parameter may leave the link out (0), and the
        row then keeps ``i`` clear of the zone's centre only."""
        if not self.structure.route:
            return delta2
        return delta2 * (1 - self.params["unlinked"][q, i])

    def _comm_keep_out(self, i: int, z: Any) -> tuple[Any, Any, Any]:
        """The keep-out margin of eq. 7d (without the teammate term) for robot ``i``."""
        return self.pieces["keep_out"](
            self.xps[i], z[CommRow.GAUSSIAN], z[CommRow.CLEARANCE], z[CommRow.BETA]
        )

    def _constraints(self) -> ConstraintRows:
        """Every robot's rows: its sensing zones, then its comm zones × teammates."""
        return self._slot_constraints() if self.slots else self._full_constraints()

    def _full_constraints(self) -> ConstraintRows:
        s, v, dt = self.structure, self.variables, self.params["dt"]
        n, szones, czones = s.n_robots, self.params["sensing_zones"], self.params["comm_zones"]
        rows = ConstraintRows()
        pairs: dict[tuple[int, int], Any] = {}
        if s.n_comm_zones:
            for i in range(n):
                for q in range(i + 1, n):
                    pairs[i, q] = self.pieces["pair"](self.xps[i], self.xps[q])
        for i in range(n):
            for zl in range(s.n_sensing_zones):
                self._sensing_row(rows, i, szones[:, zl], v.nu(i, zl))
            for zk in range(s.n_comm_zones):
                z = czones[:, zk]
                delta2 = z[CommRow.DELTA2]
                h, dh, ddh = self._comm_keep_out(i, z)
                for q in range(n):
                    if q == i:
                        continue
                    d2 = self._linked_delta2(delta2, i, q)
                    value, grad_pair, hess_pair = pairs[min(i, q), max(i, q)]
                    # ∂‖x_i − x_q‖/∂x_i = grad_pair if i < q, −grad_pair otherwise
                    gp = grad_pair if i < q else -grad_pair
                    r = len(rows.g)
                    rows.g.append(h - d2 * value + self.xi[zk, i])
                    di, dq = dh - d2 * gp, d2 * gp
                    rows.jrows.extend([r, r, r, r, r])
                    rows.jcols.extend([v.u(i), v.u(i) + 1, v.u(q), v.u(q) + 1, v.xi(i, zk)])
                    rows.jvals.extend([dt * di[0], dt * di[1], dt * dq[0], dt * dq[1], ca.SX(1)])
                    rows.own.append((r, i, ddh))
                    rows.pair.append((r, i, [(q, ca.SX(1))], d2 * hess_pair))
        return rows

    def _slot_constraints(self) -> ConstraintRows:
        """The reduced problem: zones and teammates picked by the one-hot parameters (a left-out
        link of the route program is never picked, so every slot row keeps the zone's ``δ2``)."""
        assert self.slots is not None
        n, v, dt = self.structure.n_robots, self.variables, self.params["dt"]
        szones, czones = self.params["sensing_zones"], self.params["comm_zones"]
        ssel, csel, msel = self.params["ssel"], self.params["csel"], self.params["msel"]
        n_mates = self.slots.mates
        rows = ConstraintRows()
        for i in range(n):
            for zl in range(v.n_nu):
                self._sensing_row(rows, i, ca.mtimes(szones, ssel[:, i * v.n_nu + zl]), v.nu(i, zl))
            mate_pairs = []
            for k in range(n_mates):
                weights = msel[:, i * n_mates + k]
                mates = [(q, weights[q - (q > i)]) for q in range(n) if q != i]
                partner = ca.mtimes(ca.horzcat(*[self.xps[q] for q, _ in mates]), weights)
                mate_pairs.append((mates, self.pieces["pair"](self.xps[i], partner)))
            for zk in range(v.n_xi):
                z = ca.mtimes(czones, csel[:, i * v.n_xi + zk])
                delta2 = z[CommRow.DELTA2]
                h, dh, ddh = self._comm_keep_out(i, z)
                for mates, (value, gp, hess_pair) in mate_pairs:
                    r = len(rows.g)
                    rows.g.append(h - delta2 * value + self.xi[zk, i])
                    di, dq = dh - delta2 * gp, delta2 * gp
                    rows.jrows.extend([r] * (2 * n + 1))
                    rows.jcols.extend([v.u(i), v.u(i) + 1, v.xi(i, zk)])
                    rows.jvals.extend([dt * di[0], dt * di[1], ca.SX(1)])
                    for q, wq in mates:
                        rows.jcols.extend([v.u(q), v.u(q) + 1])
                        rows.jvals.extend([wq * dt * dq[0], wq * dt * dq[1]])
                    rows.own.append((r, i, ddh))
                    rows.pair.append((r, i, mates, delta2 * hess_pair))
        return rows

    def _hessian_blocks(
        self, track: TrackingTerm, rows: ConstraintRows, lam_f: Any, lam_g: Any
    ) -> dict[tuple[int, int], Any]:
        """The exact Hessian of ``lam_f f + lam_gᵀ g``: its 2×2 blocks ``(i, q)``, ``q ≥ i``,
        of the velocities (the slacks enter linearly)."""
        n = self.structure.n_robots
        w, dt = self.params["weights"], self.params["dt"]
        diag_rest = [lam_f * w[Weight.TRACKING] * track.own[i] for i in range(n)]
        for i, pull in enumerate(self.pulls):
            diag_rest[i] = diag_rest[i] + lam_f * pull[2]
        for r, i, curv in rows.own:
            diag_rest[i] = diag_rest[i] + lam_g[r] * curv
        # −δ2 ∇²‖x_i − x_q‖ on [x_i, x_q] is −curv ⊗ [[1, −1], [−1, 1]]; keyed by q ≥ i. With
        # x_p = Σ_q w_q x_q and one-hot w (Σ w = 1, w_q w_q' = 0 for q ≠ q', w_q² = w_q), the
        # blocks are (i, i): −curv, (q, q): −w_q curv, (i, q): +w_q curv.
        pair_exact: dict[tuple[int, int], Any] = {}
        for r, i, mates, curv in rows.pair:
            term = lam_g[r] * curv
            pair_exact[i, i] = pair_exact.get((i, i), 0) - term
            for q, wq in mates:
                weighted = term if len(mates) == 1 else wq * term
                key = (min(i, q), max(i, q))
                pair_exact[q, q] = pair_exact.get((q, q), 0) - weighted
                pair_exact[key] = pair_exact.get(key, 0) + weighted
        blocks: dict[tuple[int, int], Any] = {}
        for i in range(n):
            for q in range(i, n):
                gn = track.gauss_newton[i, q]
                blk = lam_f * w[Weight.TRACKING] * gn + pair_exact.get((i, q), 0)
                if i == q:  # plus the effort term's 2 w2 I
                    blk = dt * dt * (blk + diag_rest[i]) + 2 * lam_f * w[Weight.EFFORT] * ca.SX.eye(
                        2
                    )
                else:
                    blk = dt * dt * blk
                blocks[i, q] = blk
        return blocks

    def _build_functions(
        self, f: Any, grad: list[Any], track: TrackingTerm, rows: ConstraintRows
    ) -> None:
        x, p, n, nx = self.x, self.p, self.structure.n_robots, self.n_vars
        ng = len(rows.g)
        self.n_constraints = ng
        g_vec = ca.vertcat(*rows.g) if rows.g else ca.SX(0, 1)
        jac = (
            ca.SX.triplet(rows.jrows, rows.jcols, ca.vertcat(*rows.jvals), ng, nx)
            if ng
            else ca.SX(0, nx)
        )
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
        lam_f = ca.SX.sym("lam_f")
        lam_g = ca.SX.sym("lam_g", ng)
        hess_in = [x, p, lam_f, lam_g]
        hess_names = ["x", "p", "lam_f", "lam_g"]
        exact_blocks = self._hessian_blocks(track, rows, lam_f, lam_g)
        exact, exact_triu = assemble(exact_blocks, n, nx, 0.0)
        # the SQP's: each diagonal block's eigenvalues clipped at ``margin``
        clipped_blocks = self._hessian_blocks(track, rows, lam_f, lam_g)
        for i in range(n):
            clipped_blocks[i, i] = psd_clip(clipped_blocks[i, i], self.margin)
        variants = {
            "hess_exact": exact,
            "hess_clip": assemble(clipped_blocks, n, nx, SLACK_CURVATURE)[0],
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
        self.jobs: dict[tuple[str, str], CompiledFunctions | None] = {}
