"""What the league and SOG problems share: solvers built per method on first use, on compiled
code (:mod:`~.codegen`) when the library of the method's functions is ready, else on CasADi's
virtual machine.

A subclass names its symbolic problem, the functions a solver of each method is given and how
their library is labelled; :class:`CompiledProblem` starts (or finds) the compile job, loads
the library, falls back to the virtual machine when it does not load, creates the solver with
the package's options and wraps it in a :class:`~.compiled_call.BufferedCall`.
"""

from __future__ import annotations

import logging
from typing import Any, Protocol

import casadi as ca
import numpy as np

from resilient_tracking import interrupts
from resilient_tracking.planning import codegen
from resilient_tracking.planning import codegen_status as status
from resilient_tracking.planning.compile_jobs import CompiledFunctions
from resilient_tracking.planning.compiled_call import BufferedCall, quiet_stdout
from resilient_tracking.planning.nlp_cache import count_solver_build
from resilient_tracking.planning.solver_options import (
    COMMON_OPTIONS,
    IPOPT_OPTIONS,
    METHODS,
    SQP_OPTIONS,
    ProblemOptions,
)

log = logging.getLogger(__name__)


class SymbolicProblem(Protocol):
    """A symbolic problem shared process-wide (``LeagueNLP``, ``SogNLP``): its CasADi NLP,
    sizes, and the compile jobs of its functions."""

    nlp: dict[str, Any]
    n_vars: int
    n_params: int
    n_constraints: int
    jobs: dict[Any, CompiledFunctions | None]


class CompiledProblem:
    """Solvers of one problem by method, each created on first use (see the module docstring).

    Subclasses define :meth:`symbolic`, :meth:`roles`, :meth:`compile_label` and
    :meth:`_build` (usually through :meth:`_nlpsol`)."""

    def __init__(self, options: ProblemOptions, default_method: str):
        self.options = options
        self.default_method = default_method
        self._calls: dict[str, BufferedCall] = {}

    # ------------------------------------------------------------------ what a subclass says

    def symbolic(self, method: str) -> SymbolicProblem:
        """The symbolic problem a solver of ``method`` solves."""
        raise NotImplementedError

    def roles(self, method: str) -> dict[str, ca.Function]:
        """The functions a solver of ``method`` is given, by the CasADi option they are given
        as (those compiled into its library)."""
        raise NotImplementedError

    def compile_label(self, method: str) -> tuple[Any, str, str | None]:
        """How ``method``'s compile job is known: its key in the symbolic problem's ``jobs``,
        the library's label, and what defines its functions (to find the library through the
        index, :mod:`~.library_index`) or None."""
        raise NotImplementedError

    def _build(self, method: str, functions: dict[str, ca.Function], compiled: bool) -> Any:
        """The CasADi solver of ``method`` given ``functions`` (compiled ones if ``compiled``)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ solvers

    def solver(self, method: str | None = None) -> ca.Function:
        """The CasADi solver of ``method`` (built on first use)."""
        return self._call(method or self.default_method).solver

    def compiled(self, method: str | None = None) -> bool:
        """Whether ``method`` runs on compiled code."""
        return self._call(method or self.default_method).compiled

    def _job(self, method: str) -> CompiledFunctions | None:
        """The (shared) compile job of ``method``'s functions, started on first use; None when
        codegen is off (also when it was turned off after a job had started). An error of the
        compiled path turns codegen off (:func:`~.codegen.turn_off`): never a failed solve."""
        if not self.options.codegen:
            return None
        try:
            if not codegen.enabled():
                return None
        except Exception as err:  # a setting changed during the run
            interrupts.reraise(err)
            codegen.turn_off(err, "reading the settings")
            return None
        jobs = self.symbolic(method).jobs
        key, label, defines = self.compile_label(method)
        if key not in jobs:
            functions = self.roles(method)
            try:
                jobs[key] = codegen.compile_functions(functions, label, defines)
            except Exception as err:
                interrupts.reraise(err)
                codegen.turn_off(err, f"starting the compiled code of {label}")
                return None
        return jobs[key]

    def _call(self, method: str) -> BufferedCall:
        if method not in self._calls:
            self._calls[method] = self._new_call(method, self._job(method))
        return self._calls[method]

    def _switch_to_compiled(self, method: str) -> None:
        """Block until ``method``'s compiled code is ready, and use it from now on."""
        job = self._job(method)
        try:
            usable = job is not None and job.wait()
        except Exception as err:
            interrupts.reraise(err)
            codegen.turn_off(err, f"waiting for {job.library.name if job else method}")
            usable = False
        if usable and not self._call(method).compiled:
            self._calls[method] = self._new_call(method, job)

    def _new_call(self, method: str, job: CompiledFunctions | None) -> BufferedCall:
        functions = self.roles(method)
        compiled = False
        if job is not None:
            try:
                compiled = job.ready()
            except Exception as err:
                interrupts.reraise(err)
                codegen.turn_off(err, f"finishing {job.library.name}")
        if compiled and job is not None:
            try:
                functions = job.load()
            except RuntimeError as err:  # a broken library: stay on the virtual machine
                interrupts.reraise(err)
                log.warning("loading %s failed: %s", job.library, err)
                status.record_failure(f"loading {job.library.name} failed: {err}")
                job.failed, compiled = True, False
                functions = self.roles(method)
        problem = self.symbolic(method)
        solver = self._build(method, functions, compiled)
        count_solver_build()
        call = BufferedCall(solver, problem.n_vars, problem.n_params, problem.n_constraints)
        call.compiled = compiled
        return call

    def _nlpsol(
        self, name: str, method: str, problem: Any, functions: dict[str, ca.Function]
    ) -> ca.Function:
        """``ca.nlpsol`` of ``problem`` for ``method`` (``"ipopt"`` or ``"sqp"``) with the package's
        options and this problem's, ``functions`` given as the solver's options of their name."""
        if method not in METHODS:
            raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
        opts: dict[str, Any] = dict(COMMON_OPTIONS)
        if method == "ipopt":
            opts.update(functions, ipopt={**IPOPT_OPTIONS, **self.options.ipopt})
            return ca.nlpsol(name, "ipopt", problem, opts)
        opts.update(SQP_OPTIONS)
        opts.update(self.options.sqp)
        opts.update(
            functions,
            qpsol=self.options.qpsol,
            qpsol_options=self.options.qpsol_options(),
        )
        with quiet_stdout():  # qpOASES prints a licence banner when its memory is set up
            return ca.nlpsol(name, "sqpmethod", problem, opts)

    # ------------------------------------------------------------------ one step

    @staticmethod
    def start_point(
        warm: dict[str, np.ndarray] | None, lbx: np.ndarray, ubx: np.ndarray, n_constraints: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Primal start (within the bounds) and dual starts ``(x0, lam_x0, lam_g0)``: those of a
        previous solution ``warm``, else zero velocities and zero multipliers."""
        if warm is not None:
            return np.clip(warm["x"], lbx, ubx), warm["lam_x"], warm["lam_g"]
        n_vars = len(lbx)
        return np.clip(np.zeros(n_vars), lbx, ubx), np.zeros(n_vars), np.zeros(n_constraints)
