"""Solve league problems: cached by structure, warm-started, never crashing (docs/model.md §9).

The solver ladder per solve (``solver="ladder"``, the default):

1. ``"sqp"`` — CasADi's ``sqpmethod`` with qpOASES, warm-started from the previous step's
   primal *and* dual solution of the same league (cold from zero when there is none);
2. ``"warm"`` — IPOPT from the same primal–dual warm start (skipped when there is none);
3. ``"cold"`` — IPOPT from zero velocities and zero multipliers;
4. ``"safe"`` — hold position, clipped to the velocity bounds (inside every bound, and never
   deeper into a known zone).

With ``solver="ipopt"`` the ladder starts at rung 2. Each fallback is reported to the caller
through :attr:`PlanResult.fallback`; the policy turns it into a ``solver_fallback`` event.

Building the problem of a new league structure takes about a second at 20 robots. By default
the solve waits for it (so results do not depend on the clock). A robot loop that must answer
every period sets ``background_builds``: a new structure is then built in a worker thread
while the ladder answers with its last rung (``status`` :data:`BUILDING`), and its solvers are
used from the first solve after the build finished.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import replace
from typing import Any

import numpy as np

from resilient_tracking import interrupts
from resilient_tracking.models.sensor import PLAN_EPS, MeasurementModel
from resilient_tracking.planning.cache import LruCache
from resilient_tracking.planning.layout import ProblemInputs, Structure
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.nlp_cache import NLP_BUDGET
from resilient_tracking.planning.plan_result import PlanResult
from resilient_tracking.planning.solver_options import AUTO, SLOTS, ProblemOptions
from resilient_tracking.planning.spec import PlannerSpec, RouteSpec, SubteamSpec
from resilient_tracking.planning.subteams import SubteamPlanner

log = logging.getLogger(__name__)

#: Solver choices of :class:`LeaguePlanner`.
SOLVERS = ("ladder", "ipopt")

#: The status of a plan made while its structure is still being built in the background.
BUILDING = "structure building in the background"


#: Test hook called after every solver attempt with (rung, solution, stats); it returns the
#: pair to use instead, or raises. Fault-injection tests corrupt attempts through it.
FaultHook = Callable[[str, dict[str, Any], dict[str, Any]], tuple[dict[str, Any], dict[str, Any]]]


class SolverLadder:
    """The never-crashing ladder over any problem with ``solve(q, warm, method)`` and
    ``split(x)``: one problem per structure (built by :meth:`build`), a warm start per league
    membership. ``solver`` is ``"ladder"`` (SQP first, then IPOPT) or ``"ipopt"`` (IPOPT only).
    With ``background_builds`` a structure not yet built is built (:meth:`prepare`) in a worker
    thread, and plans answer :data:`BUILDING` from the last rung until it is ready.
    """

    #: the problem cache's budget in units of :meth:`weigh` (here: a number of problems)
    PROBLEM_BUDGET: float = 32
    #: how many league memberships keep their last solution as a warm start
    WARM_STARTS = 256

    def __init__(
        self,
        solver: str = "ladder",
        fault_hook: FaultHook | None = None,
        background_builds: bool = False,
    ):
        if solver not in SOLVERS:
            raise ValueError(f"solver: expected one of {SOLVERS}, got {solver!r}")
        self.solver = solver
        self.fault_hook = fault_hook
        self.background_builds = background_builds
        #: running free against the clock: only the first rung is tried, and a failure takes
        #: the safe action at once (an IPOPT rung after a failed SQP has no time bound)
        self.first_rung_only = False
        self._builder: ThreadPoolExecutor | None = None
        self._building: dict[Any, Future[Any]] = {}
        self._lock = threading.Lock()
        # bounded, so that a long mission meeting ever new structures keeps a flat memory
        self._problems: LruCache[Any, Any] = LruCache(
            self.PROBLEM_BUDGET, weigh=self.weigh, on_evict=self._forget
        )
        self._warm: OrderedDict[tuple[Any, tuple[int, ...]], dict[str, np.ndarray]] = OrderedDict()

    def build(self, structure: Any) -> Any:
        """The problem of ``structure``; subclasses say how to build it."""
        raise NotImplementedError

    def prepare(self, structure: Any) -> Any:
        """The problem of ``structure`` with everything its solves will need already built
        (what a background build does; by default just :meth:`build`)."""
        return self.build(structure)

    def ready_problem(self, structure: Any) -> Any | None:
        """The problem of ``structure``; None while it is being built in the background."""
        if not self.background_builds or structure in self._problems:
            return self.problem(structure)
        with self._lock:
            future = self._building.get(structure)
            if future is None:
                if self._builder is None:
                    self._builder = ThreadPoolExecutor(1, thread_name_prefix="rtrack-build")
                log.info("building the problem of %s in the background", structure)
                self._building[structure] = self._builder.submit(self.prepare, structure)
                return None
            if not future.done():
                return None
            del self._building[structure]
        built = future.result()  # a failed build raises here, where plan() handles it
        return self._problems.get(structure, lambda: built)

    def close(self) -> None:
        """Stop background building (a build under way finishes in its thread; none starts)."""
        if self._builder is not None:
            self._builder.shutdown(wait=False, cancel_futures=True)
            self._builder = None
        self._building.clear()

    def weigh(self, problem: Any) -> float:
        """A problem's share of :attr:`PROBLEM_BUDGET`."""
        return 1.0

    def problem(self, structure: Any) -> Any:
        """The problem of ``structure``, from the cache or built now (:meth:`build`)."""

        def build() -> Any:
            log.debug("building %s for %s", type(self).__name__, structure)
            return self.build(structure)

        return self._problems.get(structure, build)

    def _forget(self, structure: Any, problem: Any) -> None:
        for key in [key for key in self._warm if key[0] == structure]:
            del self._warm[key]

    def _keep_warm(self, key: tuple[Any, tuple[int, ...]], solution: dict[str, np.ndarray]) -> None:
        self._warm[key] = solution
        self._warm.move_to_end(key)
        while len(self._warm) > self.WARM_STARTS:
            self._warm.popitem(last=False)

    def rungs(self, warm: dict[str, np.ndarray] | None) -> list[tuple[str, str, bool]]:
        """The attempts for one solve: (rung name, method, use the warm start)."""
        rungs = [("sqp", "sqp", warm is not None)] if self.solver == "ladder" else []
        if warm is not None:
            rungs.append(("warm", "ipopt", True))
        rungs.append(("cold", "ipopt", False))
        return rungs

    def plan(self, structure: Any, members: tuple[int, ...], q: Any) -> PlanResult:
        """Controls ``(n, 2)`` for one league: each rung of :meth:`rungs` in turn until one succeeds
        with finite numbers (clipped to the bounds, its solution kept as the membership's next warm
        start), else hold position; every attempt is recorded in the :class:`PlanResult`, and no
        exception escapes."""
        key = (structure, members)
        warm = self._warm.get(key)
        start = time.perf_counter()
        status, iterations = "not solved", 0
        attempts: list[tuple[str, str]] = []
        try:
            problem = self.ready_problem(structure)
        except Exception as err:  # building a problem must not crash an episode either
            interrupts.reraise(err)
            log.warning("building the league problem raised %s: %s", type(err).__name__, err)
            status = f"exception: {type(err).__name__}"
            attempts.append(("build", status))
            return self._safe(structure, members, q, status, iterations, attempts, start)
        if problem is None:
            attempts.append(("build", BUILDING))
            return self._safe(structure, members, q, BUILDING, iterations, attempts, start)
        for k, (rung, method, use_warm) in enumerate(self.rungs(warm)):
            if k > 0 and self.first_rung_only:
                break
            try:
                solution, stats = problem.solve(q, warm if use_warm else None, method)
                if self.fault_hook is not None:
                    solution, stats = self.fault_hook(rung, solution, stats)
                status = str(stats.get("return_status", "unknown"))
                iterations += int(stats.get("iter_count", 0))
                x = np.asarray(solution["x"])
                controls = problem.split(x)
            except Exception as err:  # a solver must never crash an episode
                interrupts.reraise(err)  # an interrupt is not a failed solve
                log.warning("league solve (%s) raised %s: %s", rung, type(err).__name__, err)
                status = f"exception: {type(err).__name__}"
                attempts.append((rung, status))
                continue
            attempts.append((rung, status))
            if stats.get("success", False) and np.all(np.isfinite(x)):
                self._keep_warm(key, solution)
                return PlanResult(
                    controls=np.clip(controls, q.u_lower, q.u_upper),
                    status=status,
                    success=True,
                    iterations=iterations,
                    solve_ms=(time.perf_counter() - start) * 1e3,
                    fallback=rung if k > 0 else "",
                    rung=rung,
                    attempts=tuple(attempts),
                )
            log.debug("league %s: %s attempt failed (%s)", members, rung, status)
        return self._safe(structure, members, q, status, iterations, attempts, start)

    def _safe(
        self,
        structure: Any,
        members: tuple[int, ...],
        q: Any,
        status: str,
        iterations: int,
        attempts: list[tuple[str, str]],
        start: float,
    ) -> PlanResult:
        """The last rung: hold position (the policy may replace it with a safe action)."""
        self._warm.pop((structure, members), None)
        log.info("league %s: solver failed (%s); holding position", members, status)
        return PlanResult(
            controls=np.clip(np.zeros((structure.n_robots, 2)), q.u_lower, q.u_upper),
            status=status,
            success=False,
            iterations=iterations,
            solve_ms=(time.perf_counter() - start) * 1e3,
            fallback="safe",
            rung="safe",
            attempts=tuple(attempts),
        )


class LeaguePlanner(SolverLadder):
    """The ladder over the league problems of docs/model.md §5; ``options`` are passed to every
    :class:`LeagueProblem`.

    ``route`` selects the planner program: ``None`` for the paper's one-step program, else
    the route program with these parameters (policies then add route rows to their inputs,
    see :mod:`resilient_tracking.planning.goals`).
    """

    def __init__(
        self,
        solver: str = "ladder",
        fault_hook: FaultHook | None = None,
        options: ProblemOptions | dict[str, Any] | None = None,
        route: RouteSpec | None = None,
        background_builds: bool = False,
        subteams: SubteamSpec | None = None,
    ):
        super().__init__(solver, fault_hook, background_builds)
        #: checked here, before any episode runs: an unknown key is an error naming it
        self.options = ProblemOptions.of(options)
        self.route = route
        #: plans leagues larger than ``subteams.above`` as sub-teams, each sub-team's window
        #: with :attr:`windows`; None: always jointly
        self.subteams: SubteamPlanner | None = None
        self.windows: LeaguePlanner | None = None
        if subteams is not None:
            self.windows = LeaguePlanner(
                solver,
                fault_hook,
                _window_options(self.options, subteams),
                route,
                background_builds,
            )
            self.subteams = SubteamPlanner(subteams, self.windows.plan)

    @classmethod
    def from_spec(cls, spec: PlannerSpec, fault_hook: FaultHook | None = None) -> LeaguePlanner:
        """The planner a scenario's ``planner`` section asks for."""
        route = spec.route if spec.program == "route" else None
        return cls(spec.solver, fault_hook=fault_hook, route=route, subteams=spec.subteams)

    #: weighed in instructions of symbolic code, like the shared cache of symbolic problems
    PROBLEM_BUDGET = NLP_BUDGET

    def build(self, structure: Structure) -> LeagueProblem:
        """The league NLP of ``structure`` with this planner's options."""
        return LeagueProblem(structure, "ipopt", self.options)

    def prepare(self, structure: Structure) -> LeagueProblem:
        """The problem with the solvers its rungs will use already set up (a background build)."""
        problem = self.build(structure)
        problem.prepare(("sqp", "ipopt") if self.solver == "ladder" else ("ipopt",))
        return problem

    def prepare_team(
        self, n_robots: int, n_targets: int, sensor: MeasurementModel
    ) -> Structure | None:
        """Before a run: build the window problem a team of ``n_robots`` plans its large leagues
        with (:mod:`~resilient_tracking.planning.subteams`), and wait for its compiled code
        (compiled once per machine, then loaded from the cache), so that no structure of a
        large league is built during the run. Returns that structure; None when the team is
        never planned as sub-teams."""
        if self.subteams is None or n_robots <= self.subteams.spec.above:
            return None
        self.subteams.sensor, self.subteams.large_team = sensor, True
        standoff = PLAN_EPS if self.route is None else self.route.standoff
        structure = self.subteams.structure(
            n_targets, self.route is not None, standoff, type(sensor)
        )
        methods = ("sqp", "ipopt") if self.solver == "ladder" else ("ipopt",)
        started = time.perf_counter()
        log.info("building the sub-team problem %s", structure.label)
        assert self.windows is not None
        problem = self.windows.problem(structure)
        problem.prepare(methods)
        problem.wait_for_compiler(methods)
        log.info(
            "sub-team problem %s ready in %.1f s", structure.label, time.perf_counter() - started
        )
        return structure

    def weigh(self, problem: LeagueProblem) -> float:
        """A problem's cache weight: the instructions of its symbolic code."""
        return float(problem.n_instructions)

    def problem(self, structure: Structure) -> LeagueProblem:
        """The :class:`LeagueProblem` of ``structure``, cached."""
        problem: LeagueProblem = super().problem(structure)
        return problem

    def plan(self, structure: Structure, members: tuple[int, ...], q: ProblemInputs) -> PlanResult:
        """Controls ``(n, 2)`` for one league from inputs ``q`` (see :meth:`SolverLadder.plan`);
        a league larger than ``subteams.above`` is planned as sub-teams
        (:mod:`~resilient_tracking.planning.subteams`)."""
        if self.subteams is not None and self.subteams.applies(structure):
            return self.subteams.plan(members, q)
        return super().plan(structure, members, q)

    def skips(self, n_robots: int) -> bool:
        """Whether a league of ``n_robots`` goes unplanned this step, past the deadline
        (:meth:`SubteamPlanner.skips`): its inputs need no route rows."""
        return self.subteams is not None and self.subteams.skips(n_robots)

    @property
    def background_builds(self) -> bool:
        """Whether new structures are built in a worker thread (the sub-team windows' too)."""
        return self._background_builds

    @background_builds.setter
    def background_builds(self, value: bool) -> None:
        self._background_builds = value
        windows = getattr(self, "windows", None)
        if windows is not None:
            windows.background_builds = value

    @property
    def deadline(self) -> float | None:
        """When (``time.perf_counter()``) a league planned as sub-teams must be planned by: its
        sub-teams not yet planned then coast or hold, and a sub-team whose SQP fails takes the
        safe action instead of trying IPOPT (running free on robots; None: none)."""
        return None if self.subteams is None else self.subteams.deadline

    @deadline.setter
    def deadline(self, value: float | None) -> None:
        if self.subteams is not None:
            self.subteams.deadline = value
        if self.windows is not None:  # against a deadline a window never falls back to IPOPT
            self.windows.first_rung_only = value is not None

    def close(self) -> None:
        """Stop background building, the sub-team windows' too."""
        super().close()
        if self.windows is not None:
            self.windows.close()


def _window_options(options: ProblemOptions, spec: SubteamSpec) -> ProblemOptions:
    """A window's problem options: the SQP's reduced problems keep a row for every teammate of
    the window (its pinned teammates are the far ones, whose rows bind together), and a window
    where a robot is near two known comm zones (their rows bind sooner with the far teammates'
    long links) has a reduced problem with two comm slots, so the full problem is rarely
    solved."""
    if options.slots != AUTO:
        return options
    mates = spec.size + spec.pinned - 1
    return replace(
        options,
        slots=(replace(SLOTS, mates=mates), replace(SLOTS, comm=2, mates=mates)),
    )
