"""Solve league problems: cached by structure, warm-started, never crashing (SPEC §7).

The ladder per solve: warm-started solve → cold solve → safe action (stay put: within every
bound, and never deeper into a known zone). Each fallback is reported to the caller.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from resilient_tracking.planning.league_problem import LeagueProblem, ProblemInputs, Structure

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlanResult:
    controls: np.ndarray  # (n, 2)
    status: str
    success: bool
    iterations: int
    solve_ms: float
    #: "" when the first attempt succeeded, else which rung was used: "cold" or "safe"
    fallback: str = ""


#: Test hook called after every solver attempt with (rung, solution, stats); it returns the
#: pair to use instead, or raises. Fault-injection tests corrupt attempts through it.
FaultHook = Callable[[str, dict[str, Any], dict[str, Any]], tuple[dict[str, Any], dict[str, Any]]]


class LeaguePlanner:
    """Holds one problem per structure and a warm start per league membership."""

    def __init__(self, solver: str = "ipopt", fault_hook: FaultHook | None = None):
        self.solver = solver
        self.fault_hook = fault_hook
        self._problems: dict[Structure, LeagueProblem] = {}
        self._warm: dict[tuple[Structure, tuple[int, ...]], dict[str, np.ndarray]] = {}

    def problem(self, structure: Structure) -> LeagueProblem:
        if structure not in self._problems:
            log.debug("building league problem %s", structure)
            self._problems[structure] = LeagueProblem(structure, self.solver)
        return self._problems[structure]

    def plan(self, structure: Structure, members: tuple[int, ...], q: ProblemInputs) -> PlanResult:
        problem = self.problem(structure)
        key = (structure, members)
        start = time.perf_counter()
        attempts = [self._warm.get(key), None] if key in self._warm else [None]
        status, iterations = "not solved", 0
        for rung, warm in enumerate(attempts):
            try:
                solution, stats = problem.solve(q, warm)
                if self.fault_hook is not None:
                    solution, stats = self.fault_hook("warm" if warm else "cold", solution, stats)
            except Exception as err:  # a solver must never crash an episode
                log.warning("league solve raised %s: %s", type(err).__name__, err)
                status = f"exception: {type(err).__name__}"
                continue
            status = str(stats.get("return_status", "unknown"))
            iterations = int(stats.get("iter_count", 0))
            controls = problem.split(solution["x"])
            if stats.get("success", False) and np.all(np.isfinite(solution["x"])):
                self._warm[key] = solution
                return PlanResult(
                    controls=np.clip(controls, q.u_lower, q.u_upper),
                    status=status,
                    success=True,
                    iterations=iterations,
                    solve_ms=(time.perf_counter() - start) * 1e3,
                    fallback="cold" if rung > 0 else "",
                )
        self._warm.pop(key, None)
        log.info("league %s: solver failed (%s); holding position", members, status)
        return PlanResult(
            controls=np.clip(np.zeros((structure.n_robots, 2)), q.u_lower, q.u_upper),
            status=status,
            success=False,
            iterations=iterations,
            solve_ms=(time.perf_counter() - start) * 1e3,
            fallback="safe",
        )
