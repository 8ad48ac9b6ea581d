"""The SOG program as it was solved before the fast path: an MX graph, IPOPT only (warm start
from the last solution, else cold), CasADi's automatic derivatives on the virtual machine.

Kept for ``benchmarks/sog_plan.py``, which replays the same steps through this and through
today's :class:`~resilient_tracking.planning.sog_problem.SogPlanner` side by side. The
expressions are those of :mod:`resilient_tracking.planning.sog_problem` (same pieces), so the
two differ only in how they are solved.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from resilient_tracking.planning.pieces import trace_of_inverse
from resilient_tracking.planning.sog_nlp import SCALARS, ZONE_COLUMNS, phi_expr
from resilient_tracking.planning.sog_problem import (
    SogInputs,
    SogProblem,
    SogStructure,
    _sog_entries,
)
from resilient_tracking.planning.solver_options import IPOPT_OPTIONS


class ReferenceSogProblem:
    """The SOG program in MX, solved by IPOPT (the code before the fast path)."""

    def __init__(self, structure: SogStructure):
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
        xp = x0 + u * dt
        phi = [phi_expr(xp[:, i], zones, c_risk, nz) for i in range(n)]
        survive = ca.vertcat(
            *[sense[i] * (1 - phi_expr(xp[:, i], zones, c_survival, nz)) for i in range(n)]
        )
        g = []
        for j in range(big_n):
            a, b, c = _sog_entries(xp, survive, targets[:, j], prior[:, j], sensor, s.sensor_model)
            g.append(rho1 + d1[j] - trace_of_inverse(a, b, c))
        if nz:
            g += [rho2 + d2[i] - phi[i] for i in range(n)]
        cost = w_e * ca.sumsqr(u) + w_t * ca.sum1(d1)
        if nz:
            cost += w_r * ca.sum1(d2)
        self.n_constraints = len(g)
        nlp = {
            "x": ca.veccat(u, d1, d2),
            "p": ca.veccat(x0, sense, targets, prior, sensor, dt, zones, k),
            "f": cost,
            "g": ca.vertcat(*g),
        }
        opts: dict[str, Any] = {"print_time": False, "error_on_fail": False}
        opts["ipopt"] = dict(IPOPT_OPTIONS)
        self.solver = ca.nlpsol(f"sog_ref_{n}x{big_n}_{nz}z", "ipopt", nlp, opts)
        # packing, bounds and splitting are unchanged
        self._layout = SogProblem.__new__(SogProblem)
        self._layout.structure = structure

    def solve(
        self, q: SogInputs, warm: dict[str, np.ndarray] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        lbx, ubx = self._layout.bounds(q)
        args: dict[str, Any] = {
            "p": self._layout.pack_params(q),
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
