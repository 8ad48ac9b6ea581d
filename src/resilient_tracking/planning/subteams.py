"""Large leagues planned as sub-teams: block coordinate descent on the league problem (eq. 9).

A league of dozens of robots is one NLP whose size grows with the square of the team (every
robot's information enters every target's trace; eq. 7d has a row per pair of teammates), and
each new league composition is a new problem to build. Above ``above`` robots the league is
planned instead as *sub-teams* of at most ``size`` robots, one after the other (a Gauss–Seidel
sweep, repeated ``sweeps`` times), each solving the same league problem over a *window*:

* its own robots, free;
* ``pinned`` teammates of other sub-teams held at their planned step (their velocity bounds
  closed on it), the ones farthest from the sub-team, so that the jamming rows (eq. 7d) that
  bind — those with the farthest teammates — see them;
* every other robot's planned measurement folded into the targets' prior information: with
  ``A_j = prior_j + Σ_i s_i m_ij(x_i⁺)`` the tracking term of the window with the others fixed
  is exactly the league's;
* the ``targets`` targets nearest to its free robots: a target far from all of them has a
  term they barely change (the information of eq. 2 fades with distance), left out.

Every window has ``size + pinned`` robots and keeps only the known zones whose rows may bind
one of its robots this step (the others hold with zero slack whatever it decides), padded to a
multiple of :data:`ZONE_BUCKET` per kind (a padding zone lies far away and binds nothing), so
one problem structure serves every sub-team, every league composition and any number of known
zones of which at most a bucket is near a window: it is built once
(:meth:`SubteamPlanner.structure`, before a run) instead of whenever the league or its
knowledge changes. A robot's plan starts from its last planned velocity.
docs/performance.md measures the time and the tracking quality against the joint solve.

Running free on robots, a *deadline* (:attr:`SubteamPlanner.deadline`) bounds a step's
planning: once the longest window of the step so far (of the step before, until one is
timed), started now, would end after it, the sub-teams not yet planned go unplanned this
step and are planned first the next step (when the deadline has passed before planning
starts, none is planned, but never two steps in a row; :meth:`SubteamPlanner.skips` tells
the policy, which then computes no route rows). Their robots keep their last planned velocity
where no known zone's row can bind within one step (the rows hold whatever they do), and hold
position (the ladder's safe action) otherwise. A league of at most ``size + pinned`` robots
(in a large team every league plans on windows, :meth:`SubteamPlanner.applies`) is always
planned, as its joint solve was. Against a deadline a window whose SQP fails takes the safe
action instead of trying IPOPT, whose time has no bound (``SolverLadder.first_rung_only``).
Simulated runs never set a deadline (their plans must not depend on the machine's speed).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from resilient_tracking.models.sensor import MeasurementModel
from resilient_tracking.planning.layout import (
    CommRow,
    ProblemInputs,
    SensingRow,
    Structure,
    ZoneNeeds,
    _information_entries,
)
from resilient_tracking.planning.pieces import piece_functions
from resilient_tracking.planning.plan_result import OVER_BUDGET, PlanResult
from resilient_tracking.planning.reduction import zone_needs
from resilient_tracking.planning.safe_action import safe_action
from resilient_tracking.planning.spec import SubteamSpec

#: Known zones per kind in a window's problem are padded up to a multiple of this.
ZONE_BUCKET = 4
#: Where a padding zone lies (m): far beyond any workspace, so its rows never bind.
FAR = 1.0e4

#: Plans one window: (structure, window members, window inputs) → its result.
PlanWindow = Callable[[Structure, tuple[int, ...], ProblemInputs], PlanResult]


def partition(positions: np.ndarray, size: int) -> list[np.ndarray]:
    """Indices of ``positions`` in ``ceil(n / size)`` spatial groups of at most ``size``:
    recursive bisection at the median of the wider axis, with the counts balanced."""
    n = len(positions)
    groups = math.ceil(n / size)

    def split(index: np.ndarray, k: int) -> list[np.ndarray]:
        if k <= 1:
            return [index]
        points = positions[index]
        axis = int(np.ptp(points[:, 1]) > np.ptp(points[:, 0]))
        order = index[np.argsort(points[:, axis], kind="stable")]
        left = k // 2
        cut = round(len(index) * left / k)
        return split(order[:cut], left) + split(order[cut:], k - left)

    return [np.sort(group) for group in split(np.arange(n), groups)]


@dataclass
class SubteamPlanner:
    """Plans leagues of more than ``spec.above`` robots as sub-teams (module docstring),
    each window through ``plan_window`` (the solver ladder)."""

    spec: SubteamSpec
    plan_window: PlanWindow
    #: whether the team has more than ``above`` robots (set before a run)
    large_team: bool = False
    #: the team's sensor, whose NumPy information model stands in for the NLP's (None: the
    #: NLP's own piece is evaluated)
    sensor: MeasurementModel | None = None
    #: when (``time.perf_counter()``) this step's planning must end: the sub-teams not yet
    #: planned by then go unplanned (module docstring); None: every sub-team is planned
    deadline: float | None = None

    def __post_init__(self) -> None:
        #: each robot's last planned velocity: where its next plan starts
        self._last: dict[int, np.ndarray] = {}
        self._pieces: dict[tuple[type, float], ca.Function] = {}
        #: when each robot was last planned (in steps planned); with a deadline the sub-teams
        #: planned longest ago go first
        self._planned_at: dict[int, int] = {}
        self._steps = 0
        #: the longest window (s) of the last step that planned one: how long the next
        #: window is expected to take, before this step has timed one of its own
        self._window_time = 0.0
        #: whether the last step planned no sub-team at all (past its deadline from the start)
        self._starved = True

    def applies(self, structure: Structure) -> bool:
        """Whether a league of this structure is planned as sub-teams: when it has more than
        ``above`` robots, and every league of a team of more than ``above``
        (:attr:`large_team`), however small, so that the parts of a split swarm plan on
        windows too (bucketed zones, the nearest targets) instead of building a problem of
        their own, with all their targets and zones, in the middle of a run."""
        return self._splits(structure.n_robots)

    def _splits(self, n: int) -> bool:
        return n > self.spec.above or self.large_team

    def structure(
        self,
        n_targets: int,
        route: bool,
        standoff: float,
        sensor_model: type[MeasurementModel],
    ) -> Structure:
        """The problem structure of every window of a team tracking ``n_targets`` (what to
        build before a run): one bucket of zone rows per kind."""
        return Structure(
            n_robots=self.spec.size + self.spec.pinned,
            n_targets=min(n_targets, self.spec.targets),
            n_sensing_zones=ZONE_BUCKET,
            n_comm_zones=ZONE_BUCKET,
            route=route,
            standoff=standoff,
            sensor_model=sensor_model,
        )

    def plan(self, members: tuple[int, ...], q: ProblemInputs) -> PlanResult:
        """Controls ``(n, 2)`` for the league ``members`` with inputs ``q``; the result sums
        the windows' iterations, takes the whole decomposition's time, succeeds when every
        window did, and reports the worst fallback."""
        started = time.perf_counter()
        n, spec = len(members), self.spec
        window = min(n, spec.size + spec.pinned)
        velocity = np.array(
            [self._last.get(robot, np.zeros(2)) for robot in members], dtype=float
        ).reshape(n, 2)
        velocity = np.clip(velocity, q.u_lower, q.u_upper)
        several = self._several(n)
        if self.skips(n):  # past the deadline already: no sub-team is planned
            self._steps += 1
            self._starved = True
            return self._league_result(members, q, velocity, np.arange(n), [], {}, started)
        info = self._information(q)
        gained = q.sensing[:, None, None] * info(q.positions + velocity * q.dt)  # (n, N, 3)
        # what every window shares this step, computed once
        shared = replace(q, prior_info=_information_entries(q.prior_info))
        robot_gaps = _distances(q.positions, q.positions)
        target_gaps = _distances(q.targets, q.positions)
        groups = partition(q.positions, spec.size)
        # a league of one window is always planned, as its joint solve would be; a larger one
        # stops at the deadline
        bounded = self.deadline is not None and several
        if bounded:  # the sub-teams planned longest ago first
            groups.sort(key=lambda g: min(self._planned_at.get(members[i], -1) for i in g))
        self._steps += 1
        results: list[PlanResult] = []
        planned: set[int] = set()
        failed: dict[int, str] = {}
        longest, expected = 0.0, self._window_time
        for _ in range(spec.sweeps):
            for g, free in enumerate(groups):
                # past the deadline: plan no more (but at least one sub-team when the last
                # step planned none, so that a slow machine still plans)
                late = bounded and self._late(time.perf_counter() + max(longest, expected))
                if late and (results or not self._starved):
                    continue
                window_started = time.perf_counter()
                outside_mask = np.ones(n, dtype=bool)
                outside_mask[free] = False
                rest = np.flatnonzero(outside_mask)
                pinned = _farthest(robot_gaps[np.ix_(rest, free)], rest, window - len(free))
                robots = np.concatenate([free, pinned])
                outside = gained[rest].sum(axis=0)  # the others' planned information
                targets = _nearest(target_gaps[:, free], spec.targets)
                sub = _binding_zones(
                    _window_inputs(shared, robots, len(free), velocity, outside, targets)
                )
                result = self.plan_window(sub.structure(), tuple(members[i] for i in robots), sub)
                results.append(result)
                planned.add(g)
                for i in free:
                    self._planned_at[members[i]] = self._steps
                longest = max(longest, time.perf_counter() - window_started)
                if result.success:
                    velocity[free] = result.controls[: len(free)]
                    for i in free:  # planned in a later sweep after all
                        failed.pop(members[i], None)
                else:  # this sub-team alone takes the safe action; the others keep their plans
                    controls, actions = safe_action(q, free)
                    velocity[free] = controls[free]
                    failed.update((members[i], actions[i]) for i in free)
                gained[free] = q.sensing[free, None, None] * info(
                    q.positions[free] + velocity[free] * q.dt
                )
        held = np.array(
            [i for g, free in enumerate(groups) if g not in planned for i in free], dtype=int
        )
        if several:
            self._starved = not results
        if several and results:
            self._window_time = longest
        return self._league_result(members, q, velocity, held, results, failed, started)

    def skips(self, n: int) -> bool:
        """Whether a league of ``n`` robots goes unplanned this step (its robots coast or
        hold): more than one window, the deadline already passed, and planned the step
        before. Its route rows need not be computed."""
        end = time.perf_counter() + self._window_time
        several = self._splits(n) and self._several(n)
        return several and self._late(end) and not self._starved

    def _several(self, n: int) -> bool:
        """Whether a league of ``n`` robots needs more than one window (the deadline bounds
        it; a league of one window is always planned)."""
        return n > self.spec.size + self.spec.pinned

    def _league_result(
        self,
        members: tuple[int, ...],
        q: ProblemInputs,
        velocity: np.ndarray,
        held: np.ndarray,
        results: list[PlanResult],
        failed: dict[int, str],
        started: float,
    ) -> PlanResult:
        """The league's result once the windows ``results`` are planned: the ``held`` robots
        (not planned) keep their last velocity where they may coast, else hold position."""
        if len(held):
            stop = held[~_free_to_coast(q, held)]
            velocity[stop] = np.clip(0.0, q.u_lower[stop], q.u_upper[stop])
        for robot, v in zip(members, velocity, strict=True):
            self._last[robot] = v.copy()
        wall_ms = (time.perf_counter() - started) * 1e3
        if not results:  # nothing planned: every robot coasts or holds
            return PlanResult(velocity.copy(), OVER_BUDGET, True, 0, wall_ms, held=tuple(members))
        held_robots = tuple(sorted(members[i] for i in held))
        combined = _combined(results, velocity, wall_ms)
        return replace(combined, held=held_robots, safe=tuple(sorted(failed.items())))

    def _late(self, end: float) -> bool:
        return self.deadline is not None and end > self.deadline

    def _information(self, q: ProblemInputs) -> Callable[[np.ndarray], np.ndarray]:
        """``positions (n, 2) → (n, N, 3)``: each robot's planning information about each
        target: the sensor's NumPy twin of the NLP's information piece when the team's
        sensor is known (:attr:`sensor`), else the piece itself, evaluated numerically."""
        targets = q.targets
        sensor = self.sensor
        if sensor is not None and type(sensor) is q.sensor_model:
            eps = float(q.standoff)
            return lambda positions: sensor.information(
                positions[:, None, :], targets[None, :, :], eps
            )
        key = (q.sensor_model, float(q.standoff))
        if key not in self._pieces:
            self._pieces[key] = piece_functions(q.sensor_model, q.standoff)["info"]
        piece, parameters = self._pieces[key], q.sensor

        def info(positions: np.ndarray) -> np.ndarray:
            m, big_n = len(positions), len(targets)
            xs = np.repeat(positions, big_n, axis=0).T
            ps = np.tile(targets, (m, 1)).T
            values = np.asarray(piece(xs, ps, parameters)[0])  # (3, m·N)
            return values.T.reshape(m, big_n, 3)

        return info


def _free_to_coast(q: ProblemInputs, robots: np.ndarray) -> np.ndarray:
    """Which of ``robots`` may keep their last planned velocity unplanned for a step: those
    no known zone's row (eq. 7c, 7d) can bind within their velocity bounds
    (:func:`~.reduction.zone_needs`); the others hold position."""
    needs = zone_needs(q)
    if needs is None:
        return np.zeros(len(robots), dtype=bool)
    return ~(needs.sensing[robots].any(axis=1) | needs.comm[robots].any(axis=1))


def _distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(len(a), len(b))`` distances between the rows of ``a`` and ``b``."""
    return np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])


def _nearest(gaps: np.ndarray, k: int) -> np.ndarray:
    """Of targets at distances ``gaps`` (targets × robots) from some robots, the ``k`` nearest
    to any of them, in index order (all when there are no more than ``k``)."""
    if len(gaps) <= k:
        return np.arange(len(gaps))
    return np.sort(np.argsort(gaps.min(axis=1), kind="stable")[:k])


def _farthest(gaps: np.ndarray, rest: np.ndarray, k: int) -> np.ndarray:
    """The ``k`` robots of ``rest`` with the largest distance to a robot of a group (``gaps``:
    rest × group; the teammates whose jamming rows bind first), in index order."""
    if k <= 0:
        return np.zeros(0, dtype=int)
    order = np.argsort(-gaps.max(axis=1), kind="stable")[:k]
    return np.sort(rest[order])


def _window_inputs(
    shared: ProblemInputs,
    robots: np.ndarray,
    n_free: int,
    velocity: np.ndarray,
    outside: np.ndarray,
    targets: np.ndarray,
) -> ProblemInputs:
    """The league inputs ``shared`` (its prior as ``(N, 3)`` information entries, its zones
    padded) restricted to ``robots`` (the first ``n_free`` free, the rest pinned at
    ``velocity``) and ``targets``, with ``outside`` information ``(N, 3)`` added to the
    prior."""
    q = shared
    pinned = robots[n_free:]
    lower, upper = q.u_lower[robots].copy(), q.u_upper[robots].copy()
    lower[n_free:] = upper[n_free:] = velocity[pinned]
    sensing = q.sensing[robots].astype(float)
    sensing[n_free:] = 0.0  # their information is in ``outside``
    a, b, c = (q.prior_info + outside)[targets].T
    prior_info = np.stack([np.stack([a, b], 1), np.stack([b, c], 1)], 1)
    return replace(
        q,
        positions=q.positions[robots],
        sensing=sensing,
        targets=q.targets[targets],
        prior_info=prior_info,
        u_lower=lower,
        u_upper=upper,
        route=None if q.route is None else q.route[robots],
        unlinked=None if q.unlinked is None else q.unlinked[np.ix_(robots, robots)],
    )


def _binding_zones(sub: ProblemInputs) -> ProblemInputs:
    """``sub`` with only the zones whose rows may bind one of its robots this step
    (:func:`~.reduction.zone_needs`: the others hold with zero slack whatever the window
    decides), padded to the bucket; it carries those needs, so the window's solve does not
    judge them again (a padding zone binds nothing)."""
    sensing, comm = sub.sensing_zones, sub.comm_zones
    needs = zone_needs(sub)
    if needs is not None:
        keep_s, keep_c = needs.sensing.any(axis=0), needs.comm.any(axis=0)
        sensing, comm = sensing[keep_s], comm[keep_c]
    window = replace(
        sub,
        sensing_zones=_padded(sensing, _FAR_SENSING),
        comm_zones=_padded(comm, _FAR_COMM),
    )
    if needs is not None:
        window.zone_needs = ZoneNeeds(
            _padded_columns(needs.sensing[:, keep_s], len(window.sensing_zones)),
            _padded_columns(needs.comm[:, keep_c], len(window.comm_zones)),
            needs.near,
            needs.far,
        )
    return window


def _padded_columns(need: np.ndarray, width: int) -> np.ndarray:
    """``need`` (robots × zones) with ``False`` columns for the padding zones up to ``width``."""
    return np.hstack([need, np.zeros((len(need), width - need.shape[1]), dtype=bool)])


def _bucket(count: int) -> int:
    """``count`` rounded up to a multiple of :data:`ZONE_BUCKET` (at least one bucket)."""
    return ZONE_BUCKET * max(1, math.ceil(count / ZONE_BUCKET))


#: A padding zone's row: far away, unit covariance, no keep-out radius, margin, jamming or
#: clearance (a sensing row of eq. 7c, a comm row of eq. 7d that hold with zero slack).
_FAR_SENSING = np.zeros(SensingRow.WIDTH)
_FAR_SENSING[SensingRow.MEAN] = FAR
_FAR_SENSING[SensingRow.COVARIANCE] = (1.0, 0.0, 1.0)
_FAR_COMM = np.zeros(CommRow.WIDTH)
_FAR_COMM[CommRow.MEAN] = FAR
_FAR_COMM[CommRow.COVARIANCE] = (1.0, 0.0, 1.0)


def _padded(table: np.ndarray, far: np.ndarray) -> np.ndarray:
    """``table``'s rows followed by padding rows ``far`` up to :func:`_bucket` rows."""
    table = table.reshape(-1, len(far))
    missing = _bucket(len(table)) - len(table)
    return np.vstack([table, np.tile(far, (missing, 1))])


def _combined(results: list[PlanResult], velocity: np.ndarray, wall_ms: float) -> PlanResult:
    """One league result from the windows' results, taking ``wall_ms``."""
    failed = [r for r in results if not r.success]
    worst = failed[0] if failed else max(results, key=lambda r: _RUNGS.index(r.rung or "sqp"))
    return PlanResult(
        controls=velocity.copy(),
        status=worst.status,
        success=not failed,
        iterations=sum(r.iterations for r in results),
        solve_ms=wall_ms,
        fallback=worst.fallback,
        rung=worst.rung,
        attempts=tuple(a for r in results for a in r.attempts),
    )


_RUNGS = ("sqp", "warm", "cold", "safe")
