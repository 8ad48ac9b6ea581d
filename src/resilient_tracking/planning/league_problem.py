"""A league problem ready to solve: the NLP of one structure (:mod:`~.nlp`) with its solvers,
packing, bounds and the SQP's reduced problem (:mod:`~.reduction`).

``solve`` takes the step's :class:`~.layout.ProblemInputs` and returns the solution in the
full problem's layout, whichever problem (full or reduced) and solver (SQP or IPOPT) ran.
"""

from __future__ import annotations

from dataclasses import astuple
from typing import Any

import casadi as ca
import numpy as np

from resilient_tracking.planning.compiled_problem import CompiledProblem
from resilient_tracking.planning.layout import ParameterLayout, ProblemInputs, Slots, Structure
from resilient_tracking.planning.library_index import module_digest
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.planning.nlp_cache import shared_nlp
from resilient_tracking.planning.reduction import Reduction, fill_slots, reduced_slots, zone_needs
from resilient_tracking.planning.solver_options import (
    AUTO,
    METHODS,
    REDUCE_FROM_ROWS,
    SLOTS,
    ProblemOptions,
)


class LeagueProblem(CompiledProblem):
    """A league NLP for one :class:`Structure`; solve with :meth:`solve`.

    ``solver`` is the default method of :meth:`solve`: ``"ipopt"`` (interior point with the
    exact Hessian) or ``"sqp"`` (CasADi's ``sqpmethod`` with qpOASES, see ``SQP_OPTIONS``).
    Solvers are created on first use, on compiled code when its library is in the cache
    (:mod:`~resilient_tracking.planning.codegen`; compiling starts in the background on first
    use otherwise). ``options`` are :class:`~.solver_options.ProblemOptions` (or their dict);
    by default the SQP reduces problems of ``REDUCE_FROM_ROWS`` rows or more with ``SLOTS``.

    The ``"sqp"`` method solves the reduced problem of :meth:`reduction` (only the zones and
    teammates that can bind this step) when there is one, else the full problem; its solution
    is returned in the full problem's layout either way, so warm starts pass between the two
    and the IPOPT rungs. ``options.slots`` may give several sizes of reduced problem, smallest
    first: the step's problem is solved with the first whose slots hold it.
    """

    def __init__(
        self,
        structure: Structure,
        solver: str = "ipopt",
        options: ProblemOptions | dict[str, Any] | None = None,
    ):
        if solver not in METHODS:
            raise ValueError(f"solver: expected one of {METHODS}, got {solver!r}")
        super().__init__(ProblemOptions.of(options), solver)
        self.structure = structure
        self.margin = float(self.options.margin)
        self.n_constraints = structure.n_constraints
        slots = self.options.slots
        if slots == AUTO:
            slots = SLOTS if structure.n_constraints >= REDUCE_FROM_ROWS else None
        assert not isinstance(slots, str), f"slots: unknown {slots!r}"
        levels = (slots,) if slots is None or isinstance(slots, Slots) else slots
        capped = (reduced_slots(structure, level) for level in levels)
        #: sizes of the SQP's reduced problems, smallest first, each solved by its own method
        #: (``sqp_slots``, then ``sqp_slots1``, ...); none: the SQP always solves the full one
        self.slot_methods: dict[Slots, str] = {
            level: "sqp_slots" if k == 0 else f"sqp_slots{k}"
            for k, level in enumerate(dict.fromkeys(c for c in capped if c is not None))
        }
        #: the smallest reduced problem's slots (None: never reduced)
        self.slots = next(iter(self.slot_methods), None)
        self._nlps: dict[Slots | None, LeagueNLP] = {}
        self._lbg = np.zeros(self.n_constraints)

    def prepare(self, methods: tuple[str, ...] = METHODS) -> None:
        """Build the symbolic problems and solvers of ``methods`` now rather than at the first
        solve (the SQP's reduced problems too, when it has them)."""
        for method in self._with_reduced(methods):
            self._call(method)

    def wait_for_compiler(self, methods: tuple[str, ...] = METHODS) -> None:
        """Block until the compiled code of ``methods`` is ready, and use it from now on.

        Without this, a solver keeps the code it was created with (compiled if the library was
        already in the cache): switching mid-episode would restart the solver's state at a
        moment set by the compiler's speed, which would break bit-for-bit reproducibility.
        """
        for method in self._with_reduced(methods):
            self._switch_to_compiled(method)

    def _with_reduced(self, methods: tuple[str, ...]) -> tuple[str, ...]:
        """``methods`` and, with ``"sqp"``, the methods of its reduced problems."""
        return (*methods, *self.slot_methods.values()) if "sqp" in methods else methods

    def _level(self, method: str) -> Slots | None:
        """The slots a reduced problem's method solves with (None: not a reduced method)."""
        return next((s for s, name in self.slot_methods.items() if name == method), None)

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
        """Length of the full problem's parameter vector."""
        return self.nlp.n_params

    @property
    def slot_nlp(self) -> LeagueNLP:
        """The SQP's smallest reduced problem: each robot's comm rows for ``slots`` teammates
        only."""
        return self._shared(self.slots)

    @property
    def n_instructions(self) -> int:
        """Size of the symbolic problems built for this problem so far (its cache weight)."""
        return sum(nlp.n_instructions for nlp in self._nlps.values())

    def symbolic(self, method: str) -> LeagueNLP:
        """The reduced problem of a ``"sqp_slots…"`` method, else the full problem."""
        level = self._level(method)
        return self.nlp if level is None else self._shared(level)

    def roles(self, method: str) -> dict[str, ca.Function]:
        """IPOPT's derivatives with the exact Hessian, or the SQP's ``fg``, ``jac_fg`` and its
        chosen Hessian (:attr:`~.solver_options.ProblemOptions.sqp_hessian`)."""
        fn = self.symbolic(method).functions
        if method == "ipopt":
            keys = {"grad_f": "grad_f", "jac_g": "jac_g", "hess_lag": "hess_exact_triu"}
        else:
            keys = {"fg": "fg", "jac_fg": "jac_fg", "hess_lag": "hess_" + self._sqp_hessian}
        return {role: fn[key] for role, key in keys.items()}

    @property
    def _sqp_hessian(self) -> str:
        return str(self.options.sqp_hessian)

    # ------------------------------------------------------------------ solvers

    def compile_label(self, method: str) -> tuple[tuple[str, str], str, str | None]:
        """Jobs by (method, SQP Hessian), the reduced problem's named by its slots; the key is
        what the functions are made of (the sensor model may be a plug-in: its own source
        counts too), so the library is found without generating code."""
        name = method
        level = self._level(method)
        if level is not None:
            name = "sqp_slots{}s{}c{}m".format(*astuple(level))
        s = self.structure
        sensor = module_digest(s.sensor_model)
        defines = (
            repr((s, self.margin, self.symbolic(method).slots, method, self._sqp_hessian, sensor))
            if sensor is not None
            else None
        )
        return (name, self._sqp_hessian), f"{s.label}_{name}", defines

    def _build(
        self, method: str, functions: dict[str, ca.Function], compiled: bool = False
    ) -> ca.Function:
        if method not in (*METHODS, *self.slot_methods.values()):
            raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
        name = f"{self.structure.label}_{method}"
        # f and g symbolic: CasADi derives its own helpers (never called here) from them
        nlp: Any = self.symbolic(method).nlp
        if method == "ipopt":
            return self._nlpsol(name, "ipopt", nlp, functions)
        # f and g (line search, convergence test) on compiled code too when there is some; the
        # reduced problem keeps them on the virtual machine, where its published results were
        # made (compiled code may round differently and tip a line-search decision)
        functions = dict(functions)
        fg = functions.pop("fg")
        if compiled and self._level(method) is None:
            nlp = fg
        return self._nlpsol(name, "sqp", nlp, functions)

    # ------------------------------------------------------------------ one step

    def pack_params(self, q: ProblemInputs) -> np.ndarray:
        """The parameter vector of ``q`` (:meth:`ParameterLayout.pack`)."""
        return ParameterLayout.pack(q)

    def bounds(self, q: ProblemInputs) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the decision vector: the velocity bounds ``q.u_lower``,
        ``q.u_upper`` (eq. 3), then slacks ``≥ 0``."""
        s = self.structure
        n_slack = s.n_robots * (s.n_sensing_zones + s.n_comm_zones)
        lower = np.concatenate([q.u_lower.ravel(), np.zeros(n_slack)])
        upper = np.concatenate([q.u_upper.ravel(), np.full(n_slack, np.inf)])
        return lower, upper

    def reduction(self, q: ProblemInputs) -> Reduction | None:
        """What the smallest of the SQP's reduced problems that holds this step's problem keeps
        of it (:func:`~.reduction.reduce`), or None when the full problem must be solved (also
        when this structure has no reduced problem)."""
        if not self.slot_methods:
            return None
        needs = zone_needs(q)
        for level in self.slot_methods:
            reduction = fill_slots(self.structure, level, needs, q.weights)
            if reduction is not None:
                return reduction
        return None

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
        x0, lam_x0, lam_g0 = self.start_point(warm, lbx, ubx, self.n_constraints)
        reduction = self.reduction(q) if method == "sqp" else None
        if reduction is None:
            call = self._call(method)
            solution = call(x0, self.pack_params(q), lbx, ubx, lam_x0, lam_g0, self._lbg)
            return solution, call.stats()
        call = self._call(self.slot_methods[reduction.slots])
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
