"""The SOG program (:mod:`~.sog_problem`) on the league problem's fast path: an SX problem
built once per :class:`~.sog_problem.SogStructure` and shared process-wide, its derivatives
compiled (:mod:`~.codegen`), solved by the SQP ladder (SQP with qpOASES, then IPOPT).

**The SQP's Hessian** is the league problem's (:mod:`~.nlp`): the exact Hessian of the
Lagrangian with each robot's 2×2 diagonal velocity block's eigenvalues clipped from below at
``SQP_MARGIN`` (closed form, :func:`~.hessian.psd_clip`); the slacks, which enter linearly, get
``SLACK_CURVATURE``. The rows couple robots only through the tracking requirement
``tr (P⁻⁻¹ + Σ_i c_i(u_i))⁻¹``, convex in the information matrix, so the off-diagonal blocks
stay exact. On the SOG's episodes this needs a median of 2 SQP iterations per solve and
never fell back to IPOPT (``benchmarks/sog_plan.py``), where CasADi's own ``eigen-clip`` of
the whole Hessian failed on about 1% of solves and ``regularize`` took twice the iterations.
IPOPT gets the exact Hessian (upper triangle).
"""

from __future__ import annotations

import logging
from typing import Any

import casadi as ca

from resilient_tracking.planning.cache import LruCache
from resilient_tracking.planning.compile_jobs import CompiledFunctions
from resilient_tracking.planning.hessian import psd_clip
from resilient_tracking.planning.nlp import SLACK_CURVATURE
from resilient_tracking.planning.pieces import trace_of_inverse
from resilient_tracking.planning.solver_options import SQP_MARGIN

log = logging.getLogger(__name__)

#: Columns of a zone row: mu(2), Σ⁻¹ xx/xy/yy, pdf normaliser 1/(2π√det Σ).
ZONE_COLUMNS = 6
#: Scalars: rho1, rho2, w_effort, w_track, w_risk, c of the requirement, c of the SOG.
SCALARS = 7


def phi_expr(x: Any, zones: Any, scale: Any, n_zones: int) -> Any:
    """``φ(x) = 1 − exp(−c Σ_l pdf_l(x))`` of the zone rows ``zones`` (6 × L), symbolic."""
    density = 0
    for zl in range(n_zones):
        z = zones[:, zl]
        dx, dy = x[0] - z[0], x[1] - z[1]
        m2 = z[2] * dx * dx + 2 * z[3] * dx * dy + z[4] * dy * dy
        density = density + z[5] * ca.exp(-0.5 * m2)
    return 1 - ca.exp(-scale * density)


class SogNLP:
    """The symbolic SOG program of one structure, with the functions both solvers use:
    ``fg`` → (f, g); ``jac_fg`` → (f, ∇f, g, ∂g/∂x); ``grad_f``; ``jac_g``; ``hess_exact_triu``
    (IPOPT) and ``hess_clip`` (the SQP's, see the module docstring), inputs ``x, p`` and for
    Hessians ``lam_f, lam_g``. Variables ``[u (2, n) by column, δ1 (N), δ2 (n if zones)]``;
    parameters in the order of :meth:`~.sog_problem.SogProblem.pack_params`."""

    def __init__(self, structure: Any):
        self.structure = s = structure
        n, big_n, nz = s.n_robots, s.n_targets, s.n_zones
        sx = ca.SX.sym
        u, d1, d2 = sx("u", 2, n), sx("delta1", big_n), sx("delta2", s.n_risk_slacks)
        x0, sense = sx("x", 2, n), sx("s", n)
        targets, prior = sx("targets", 2, big_n), sx("prior", 3, big_n)
        sensor, dt = sx("sensor", s.sensor_model.N_PARAMETERS), sx("dt")
        zones, k = sx("zones", ZONE_COLUMNS, nz), sx("scalars", SCALARS)
        rho1, rho2, w_e, w_t, w_r, c_risk, c_survival = (k[m] for m in range(SCALARS))
        x = ca.veccat(u, d1, d2)
        p = ca.veccat(x0, sense, targets, prior, sensor, dt, zones, k)
        self.n_vars, self.n_params = int(x.shape[0]), int(p.shape[0])

        xp = [x0[:, i] + u[:, i] * dt for i in range(n)]
        survive = [sense[i] * (1 - phi_expr(xp[i], zones, c_survival, nz)) for i in range(n)]
        # per target: the information matrix entries, and each robot's contribution c_ij
        traces = []
        for j in range(big_n):
            parts = [
                survive[i]
                * ca.vertcat(*s.sensor_model.information_casadi(xp[i], targets[:, j], sensor))
                for i in range(n)
            ]
            abc = prior[:, j] + sum(parts[1:], parts[0])
            traces.append(trace_of_inverse(abc[0], abc[1], abc[2]))
        risk = [phi_expr(xp[i], zones, c_risk, nz) for i in range(n)] if nz else []
        g = [rho1 + d1[j] - traces[j] for j in range(big_n)]
        g += [rho2 + d2[i] - risk[i] for i in range(n)] if nz else []
        f = w_e * ca.sumsqr(u) + w_t * ca.sum1(d1) + (w_r * ca.sum1(d2) if nz else 0)
        g_vec = ca.vertcat(*g)
        self.n_constraints = len(g)

        lam_f, lam_g = sx("lam_f"), sx("lam_g", self.n_constraints)
        lagrangian = lam_f * f + ca.dot(lam_g, g_vec)
        exact = ca.hessian(lagrangian, x)[0]
        blocks = ca.SX(exact)
        for i in range(n):
            rows = slice(2 * i, 2 * i + 2)
            blocks[rows, rows] = psd_clip(exact[rows, rows], SQP_MARGIN)
        for m in range(2 * n, self.n_vars):  # the slacks enter linearly
            blocks[m, m] = SLACK_CURVATURE
        jac_g = ca.jacobian(g_vec, x)
        grad_f = ca.gradient(f, x)
        xp_in, h_in = ["x", "p"], ["x", "p", "lam_f", "lam_g"]
        self.functions = {
            "fg": ca.Function("sog_fg", [x, p], [f, g_vec], xp_in, ["f", "g"]),
            "grad_f": ca.Function("sog_grad_f", [x, p], [f, grad_f], xp_in, ["f", "grad_f_x"]),
            "jac_g": ca.Function("sog_jac_g", [x, p], [g_vec, jac_g], xp_in, ["g", "jac_g_x"]),
            "jac_fg": ca.Function(
                "sog_jac_fg",
                [x, p],
                [f, grad_f, g_vec, jac_g],
                xp_in,
                ["f", "grad_f_x", "g", "jac_g_x"],
            ),
            "hess_exact_triu": ca.Function(
                "sog_hess_l",
                [x, p, lam_f, lam_g],
                [ca.triu(exact)],
                h_in,
                ["triu_hess_gamma_x_x"],
            ),
            "hess_clip": ca.Function(
                "sog_hess_l", [x, p, lam_f, lam_g], [blocks], h_in, ["hess_gamma_x_x"]
            ),
        }
        self.nlp = {"x": x, "p": p, "f": f, "g": g_vec}
        #: compile jobs of this problem's functions, by method (None: codegen is off), started
        #: by :class:`~.sog_problem.SogProblem`
        self.jobs: dict[str, CompiledFunctions | None] = {}

    def roles(self, method: str) -> dict[str, ca.Function]:
        """The functions a solver of ``method`` (``"sqp"`` or ``"ipopt"``) is given, by the
        CasADi option they are given as."""
        fn = self.functions
        if method == "ipopt":
            return {"grad_f": fn["grad_f"], "jac_g": fn["jac_g"], "hess_lag": fn["hess_exact_triu"]}
        return {"jac_fg": fn["jac_fg"], "hess_lag": fn["hess_clip"]}


#: symbolic SOG problems shared by every planner of this process (small: a few dozen at most)
_SOG_NLPS: LruCache[Any, SogNLP] = LruCache(64)


def shared_sog_nlp(structure: Any) -> SogNLP:
    """The process-wide :class:`SogNLP` of ``structure`` (built on first use)."""
    return _SOG_NLPS.get(structure, lambda: SogNLP(structure))


def wait_for_sog_compilers() -> None:
    """Block until every SOG compile job started in this process is done (for warm-ups)."""
    for nlp in _SOG_NLPS.values():
        for job in list(nlp.jobs.values()):
            if job is not None:
                job.wait()
