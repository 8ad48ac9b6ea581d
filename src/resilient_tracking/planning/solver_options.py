"""How league problems are solved: the solvers' settings and :class:`ProblemOptions`, the
options a caller may change (unknown keys are rejected by name)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

from resilient_tracking.planning.layout import Slots

#: Solver plugins a problem can be solved with.
METHODS = ("sqp", "ipopt")

#: Options of both solvers: nothing uses ``lam_p`` (∂L/∂p), which costs a reverse sweep over
#: the whole problem after each solve (≈ 0.4 ms at 20×20); and so the solver need not build
#: the Lagrangian's gradient function either (``no_nlp_grad``), which CasADi otherwise derives
#: by reverse AD at every solver creation (0.05-0.5 s at 20×20; 1-13 ms without).
COMMON_OPTIONS: dict[str, Any] = {
    "print_time": False,
    "error_on_fail": False,
    "calc_lam_p": False,
    "no_nlp_grad": True,
}
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
#: :mod:`~resilient_tracking.planning.reduction`).
SLOTS = Slots(sensing=2, comm=1, mates=6)
#: The SQP reduces only problems with at least this many rows: below it qpOASES is cheap
#: anyway (a 5×5 league with 2 + 1 zones has 30), and the paper-sized leagues keep the exact
#: solver path their published numbers were made with.
REDUCE_FROM_ROWS = 100

#: ``ProblemOptions.slots`` when the caller did not choose: ``SLOTS`` from
#: ``REDUCE_FROM_ROWS`` rows on, else never reduce.
AUTO = "auto"


@dataclass(frozen=True)
class ProblemOptions:
    """What a caller may change of how a league problem is solved.

    ``ipopt`` and ``sqp`` are CasADi option dicts merged over ``IPOPT_OPTIONS`` and
    ``SQP_OPTIONS``; ``qpsol`` is the SQP's QP solver plugin, whose options (merged over
    ``QPOASES_OPTIONS`` for qpOASES) are ``qp_options``, given in a dict under the plugin's
    own name; ``slots`` the :class:`Slots` of the SQP's reduced problem, or a tuple of them
    smallest first (each step uses the first that holds it; None: never reduce);
    ``sqp_hessian`` a Hessian of :class:`~resilient_tracking.planning.nlp.LeagueNLP` without
    ``hess_`` (``"clip"`` or ``"exact"``); ``margin`` the SQP's eigenvalue floor; ``codegen``
    False never uses compiled code.
    """

    ipopt: dict[str, Any] = field(default_factory=dict)
    sqp: dict[str, Any] = field(default_factory=dict)
    qpsol: str = "qpoases"
    qp_options: dict[str, Any] = field(default_factory=dict)
    slots: Slots | tuple[Slots, ...] | None | str = AUTO
    sqp_hessian: str = "clip"
    margin: float = SQP_MARGIN
    codegen: bool = True

    @classmethod
    def of(cls, options: ProblemOptions | dict[str, Any] | None) -> ProblemOptions:
        """Options from a dict (keys as the fields, the QP solver's options under its name);
        an unknown key is a ``ValueError`` that names it."""
        if isinstance(options, ProblemOptions):
            return options
        given = dict(options or {})
        qpsol = str(given.get("qpsol", "qpoases"))
        known = {f.name for f in fields(cls)} - {"qp_options"}
        for key in given:
            if key not in known and key != qpsol:
                expected = ", ".join(sorted(known | {qpsol}))
                raise ValueError(f"options: unknown key {key!r} (expected one of: {expected})")
        qp_options = given.pop(qpsol, {})
        return cls(**given, qp_options=dict(qp_options))

    def qpsol_options(self) -> dict[str, Any]:
        """Options of the SQP's QP solver: the project's qpOASES defaults (for qpOASES) overridden
        by ``qp_options``."""
        defaults = QPOASES_OPTIONS if self.qpsol == "qpoases" else {}
        return {**defaults, **self.qp_options}
