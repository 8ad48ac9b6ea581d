"""``check_policy``: drive a policy through hostile ticks and report every broken promise.

In the spirit of Gymnasium's environment checker. A policy is run twice, from scratch, with the
same seed, through a scripted sequence of ticks built from a scenario's team, targets and zones:
robots failing and recovering, leagues splitting and merging, no and full zone knowledge, an
isolated robot with a permanent comm failure, every robot blind, every robot cut off. The
belief is updated as in an episode (:class:`~resilient_tracking.team.Team`), then the policy's
:meth:`~resilient_tracking.policies.base.Policy.act` is called. Every tick is checked for

* building the policy, setting up its team or ``act`` raising, calling ``sys.exit`` or raising
  any other ``BaseException`` but an interrupt (reported, never raised);
* ``act`` returning something that is not a :class:`Decision`;
* controls of the wrong shape, non-finite, or outside the robots' velocity bounds;
* modes that are not one string per robot; events that are not :class:`Event` rows the events
  table can hold; plans that are not :class:`PlanResult` records the team table can count
  (every field checked as a run uses it, :mod:`~resilient_tracking.policies.checks`);
* different controls in the second run (nondeterminism under a seed);

and the policy for reaching for truth: importing or naming the simulator's world
(``resilient_tracking.world``, ``resilient_tracking.sim``, ``World``, ``TrueZone``…) in its
module, or holding a truth object. The result is a :class:`PolicyReport`, whose text lists each
violation with the tick it happened at; nothing is raised unless asked
(:meth:`PolicyReport.raise_for_violations`).
"""

from __future__ import annotations

import ast
import copy
import inspect
import logging
import textwrap
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.build import make_estimator, make_policy, team_config
from resilient_tracking.observation import Attack, TeamObservation, ZoneClue
from resilient_tracking.plugin_guard import culprit, is_escape, is_failure, what_it_did
from resilient_tracking.policies import Policy
from resilient_tracking.policies.checks import decision_problems
from resilient_tracking.rng import stream
from resilient_tracking.scenario import CommZone, Scenario
from resilient_tracking.team import Team
from resilient_tracking.team_config import TeamConfig

log = logging.getLogger(__name__)

#: Modules and class names of the simulator's truth: a policy must not use them.
TRUTH_MODULES = ("resilient_tracking.world", "resilient_tracking.sim")
TRUTH_NAMES = frozenset(
    {"World", "TrueZone", "TargetTruth", "Failure", "Surroundings", "ZoneTruth"}
)


@dataclass(frozen=True)
class Violation:
    """One broken promise: where (``tick``, the situation's name) and what."""

    tick: str
    problem: str

    def __str__(self) -> str:
        return f"[{self.tick}] {self.problem}"


@dataclass
class PolicyReport:
    """What :func:`check_policy` found: ``ok`` when ``violations`` is empty."""

    #: the policy's name
    policy: str
    #: the situations the policy was driven through, in order
    ticks: list[str] = field(default_factory=list)
    #: every violation found, in the order found
    violations: list[Violation] = field(default_factory=list)
    #: checks that could not be made, and why
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """No violation found."""
        return not self.violations

    def __str__(self) -> str:
        head = (
            f"check_policy({self.policy}): "
            + ("ok" if self.ok else f"{len(self.violations)} violation(s)")
            + f" over {len(self.ticks)} ticks, run twice"
        )
        lines = [head, *(f"  - {v}" for v in self.violations)]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)

    def raise_for_violations(self) -> None:
        """Raise :class:`PolicyCheckError` with the report's text if anything was found."""
        if not self.ok:
            raise PolicyCheckError(str(self))


class PolicyCheckError(AssertionError):
    """A policy failed :func:`check_policy`; the message is the report."""


PolicyLike = str | type[Policy] | Policy


def check_policy(policy: PolicyLike, scenario: Scenario, seed: int = 0) -> PolicyReport:
    """Drive ``policy`` through hostile ticks on ``scenario``'s team and report violations.

    ``policy`` is a name (registered, entry point or ``package.module:Class``), a
    :class:`Policy` subclass (built like :func:`make_policy` builds it) or an instance (copied
    before each of the two runs). ``seed`` seeds the measurements and the target prior.
    """
    factory, label = _factory(policy, scenario)
    report = PolicyReport(policy=label)
    try:
        first_policy = factory()
    except BaseException as err:
        if not is_failure(err):
            raise
        report.ticks = [name for name, _ in _situations(scenario)]
        report.violations.append(Violation("build", _failure("building the policy", err)))
        return report
    report.violations += _truth_violations(first_policy)
    log.info("check_policy(%s): %d situations, run twice", label, len(_situations(scenario)))
    first = _drive(first_policy, scenario, seed, report, record=True)
    try:
        second_policy = factory()
    except BaseException as err:
        if not is_failure(err):
            raise
        report.notes.append(f"determinism not checked: a second copy failed ({err})")
        return report
    second = _drive(second_policy, scenario, seed, report=None, record=False)
    for (name, a), (_, b) in zip(first, second, strict=True):
        if a is not None and b is not None and not np.array_equal(a, b, equal_nan=True):
            report.violations.append(
                Violation(name, "nondeterministic: controls differ between two runs, same seed")
            )
            break
    return report


# ---------------------------------------------------------------------------- the policy


def _factory(policy: PolicyLike, scenario: Scenario) -> tuple[Callable[[], Policy], str]:
    """A function making a fresh policy, and the policy's name."""
    if isinstance(policy, Policy):
        template = copy.deepcopy(policy)
        return (lambda: copy.deepcopy(template)), type(policy).name
    if isinstance(policy, str):
        return (lambda: make_policy(policy, scenario)), policy
    cls = policy
    if not (isinstance(cls, type) and issubclass(cls, Policy)):
        raise TypeError(f"policy: expected a name, a Policy subclass or instance, got {cls!r}")

    def build() -> Policy:
        from resilient_tracking.planning.planner import LeaguePlanner

        config = team_config(scenario)
        params = scenario.policy.params_for(cls.name, cls.Params)
        planner = LeaguePlanner.from_spec(scenario.planner)
        return cls.build(config, params, planner, scenario.guards)

    return build, cls.name


def _failure(what: str, err: BaseException) -> str:
    """One line for an exception: where it was raised (file:line), never a traceback; for an
    exit or another escape past ``except Exception``, which code did it."""
    if is_escape(err):
        found = culprit(err.__traceback__)
        return f"{what} {what_it_did(err)}" + (f" in {found}" if found is not None else "")
    frames = inspect.trace()
    where = f" at {Path(frames[-1].filename).name}:{frames[-1].lineno}" if frames else ""
    return f"{what} raised {type(err).__name__}: {err}{where}"


def _truth_violations(policy: Policy) -> list[Violation]:
    """Reaching for truth: the policy's own modules import or name the world, or the policy
    holds a truth object."""
    out: list[Violation] = []
    for cls in type(policy).__mro__:
        if cls in (Policy, object) or cls.__module__.startswith("resilient_tracking.policies"):
            continue
        try:
            path = Path(inspect.getfile(cls))
            module = ast.parse(path.read_text())
            body = ast.parse(textwrap.dedent(inspect.getsource(cls)))
        except (TypeError, OSError, SyntaxError):
            continue
        # the class itself, and the imports at the top of its module
        imports = [n for n in module.body if isinstance(n, ast.Import | ast.ImportFrom)]
        for problem in dict.fromkeys([*_truth_in_source(body), *_truth_in_nodes(imports)]):
            out.append(Violation("source", f"{cls.__name__} ({path.name}): {problem}"))
    for name, value in vars(policy).items():
        if _is_truth(value):
            out.append(Violation("state", f"attribute {name!r} holds a truth object"))
    return out


def _truth_in_source(tree: ast.AST) -> Iterator[str]:
    """Truth modules imported and truth classes named anywhere in ``tree``."""
    yield from _truth_in_nodes(list(ast.walk(tree)))


def _truth_in_nodes(nodes: Sequence[ast.AST]) -> Iterator[str]:
    for node in nodes:
        modules: list[str] = []
        if isinstance(node, ast.Import):
            modules = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            modules = [node.module]
        for module in modules:
            if module.startswith(TRUTH_MODULES):
                yield f"imports {module} (the simulator's truth)"
        if isinstance(node, ast.Name) and node.id in TRUTH_NAMES:
            yield f"names {node.id} (the simulator's truth)"


def _is_truth(value: Any) -> bool:
    module = type(value).__module__
    return isinstance(module, str) and module.startswith(TRUTH_MODULES)


# ---------------------------------------------------------------------------- driving


def _drive(
    policy: Policy, scenario: Scenario, seed: int, report: PolicyReport | None, record: bool
) -> list[tuple[str, np.ndarray | None]]:
    """Run the situations once; check each tick into ``report``; the controls per tick."""
    config = policy.config
    m, n = len(scenario.robots), len(scenario.targets)
    targets = np.array([t.start for t in scenario.targets], dtype=float)
    prior = scenario.estimator
    rng = stream(seed, "policy_check")
    means = np.column_stack([targets, np.zeros((n, 2))])
    noise = rng.standard_normal(means.shape) * prior.initial_position_std
    try:
        team = Team(
            policy,
            TargetEstimate.initial(
                means + noise, prior.initial_position_std, prior.initial_velocity_std
            ),
            make_estimator(scenario, config),
            scenario.belief,
        )
    except BaseException as err:  # belief_needs() and learns_zones are the policy's code
        if not is_failure(err):
            raise
        if report is not None:
            report.ticks += [name for name, _ in _situations(scenario)] if record else []
            report.violations.append(Violation("setup", _failure("setting up its team", err)))
        return [(name, None) for name, _ in _situations(scenario)]
    positions = np.array([r.start for r in scenario.robots], dtype=float)
    out: list[tuple[str, np.ndarray | None]] = []
    for k, (name, situation) in enumerate(_situations(scenario)):
        if record and report is not None:
            report.ticks.append(name)
        obs = situation(k, positions, _measure(config, positions, targets, rng))
        try:
            team.belief.update(obs)
            decision = policy.act(team.belief, obs)
        except BaseException as err:
            if not is_failure(err):
                raise
            if report is not None:
                report.violations.append(Violation(name, _failure("act", err)))
            out.append((name, None))
            continue
        controls = _check_decision(decision, config, obs, name, report)
        out.append((name, controls))
        if controls is not None and np.all(np.isfinite(controls)):
            lower, upper = config.velocity_bounds(list(range(m)), positions)
            positions = positions + np.clip(controls, lower, upper) * config.dt
        for value in vars(policy).values():
            if _is_truth(value) and report is not None:
                report.violations.append(Violation(name, "the policy holds a truth object"))
    return out


def _check_decision(
    decision: Any, config: TeamConfig, obs: TeamObservation, tick: str, report: PolicyReport | None
) -> np.ndarray | None:
    """The decision's controls if they have the right shape; violations into ``report``."""
    controls, problems = decision_problems(decision, config, obs.positions)
    messages = [p.message for p in problems if p.robot is None]
    for kind, words in (("not_finite", "are not finite"), ("out_of_bounds", "are outside")):
        found = [p for p in problems if p.kind == kind]
        if found:
            robots = [p.robot for p in found]
            messages.append(f"controls of robots {robots} {words} (robot {found[0].message})")
    if report is not None:
        report.violations += [Violation(tick, m) for m in messages]
    return controls


def _measure(
    config: TeamConfig, positions: np.ndarray, targets: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Noisy measurements of every target by every robot (``NaN`` beyond the sensor's range)."""
    z = config.sensor.sample(positions[:, None, :], targets[None, :, :], rng)
    distance = np.linalg.norm(targets[None, :, :] - positions[:, None, :], axis=-1)
    z[~config.sensor.in_range(distance)] = np.nan
    return z


# ---------------------------------------------------------------------------- situations

Situation = Callable[[int, np.ndarray, np.ndarray], TeamObservation]


def _clues(scenario: Scenario, positions: np.ndarray) -> tuple[ZoneClue, ZoneClue]:
    """A sensing and a comm clue: from the scenario's zones, or made up near robot 0."""
    sensing = next((z for z in scenario.zones if z.kind == "sensing"), None)
    comm = next((z for z in scenario.zones if isinstance(z, CommZone)), None)
    near = positions[0] + 0.5
    cov = 0.1 * np.eye(2)

    def clue(zone: Any, zone_id: int, kind: Any, size: float, persistence: Any) -> ZoneClue:
        if zone is None:
            return ZoneClue(zone_id, kind, near.copy(), cov.copy(), size, persistence)
        return ZoneClue(
            scenario.zones.index(zone),
            kind,
            np.asarray(zone.mu, dtype=float),
            np.asarray(zone.sigma, dtype=float),
            float(zone.radius if kind == "sensing" else zone.delta2),
            persistence,
        )

    return (
        clue(sensing, 0, "sensing", 0.5, "temporary"),
        clue(comm, 1, "comm", 0.3, "permanent"),
    )


def _situations(scenario: Scenario) -> list[tuple[str, Situation]]:
    """The scripted ticks: name and a function (step, positions, measurements) → observation."""
    m = len(scenario.robots)
    full = np.ones((m, m), dtype=bool)
    np.fill_diagonal(full, False)
    alone = m - 1  # the robot cut off in the isolation ticks

    def observe(
        sensing: np.ndarray | None = None,
        comm: np.ndarray | None = None,
        links: np.ndarray | None = None,
        comm_persistence: dict[int, str] | None = None,
        attacks: tuple[Attack, ...] = (),
        recoveries: tuple[tuple[int, Any], ...] = (),
        all_clues: bool = False,
    ) -> Situation:
        def make(step: int, positions: np.ndarray, z: np.ndarray) -> TeamObservation:
            ok_s = np.ones(m, dtype=bool) if sensing is None else sensing
            ok_c = np.ones(m, dtype=bool) if comm is None else comm
            z = z.copy()
            z[~ok_s] = np.nan
            found = attacks
            if all_clues:
                s_clue, c_clue = _clues(scenario, positions)
                found = (Attack(0, s_clue), Attack(alone, c_clue))
            persistence = ["" if ok else "temporary" for ok in ok_c]
            for i, p in (comm_persistence or {}).items():
                persistence[i] = p
            return TeamObservation(
                step=step,
                time=step * scenario.dt,
                positions=positions.copy(),
                measurements=z,
                sensing_ok=ok_s,
                comm_ok=ok_c,
                sensing_persistence=tuple("" if ok else "temporary" for ok in ok_s),
                comm_persistence=tuple(persistence),
                links=full.copy() if links is None else links,
                attacks=found,
                recoveries=recoveries,
            )

        return make

    def without(robots: list[int]) -> np.ndarray:
        links = full.copy()
        links[robots, :] = False
        links[:, robots] = False
        return links

    def flags(off: list[int]) -> np.ndarray:
        ok = np.ones(m, dtype=bool)
        ok[off] = False
        return ok

    half = max(1, m // 2)
    split = full.copy()
    split[:half, half:] = False
    split[half:, :half] = False
    none = np.zeros((m, m), dtype=bool)
    return [
        ("all well, no zone knowledge", observe()),
        ("robot 0 loses its sensor (attacked)", observe(sensing=flags([0]), all_clues=True)),
        ("the league splits in two", observe(sensing=flags([0]), links=split)),
        (
            "the leagues merge, robot 0 recovers",
            observe(recoveries=((0, "sensing"),)),
        ),
        (
            f"robot {alone} isolated by a permanent comm failure",
            observe(
                comm=flags([alone]),
                links=without([alone]),
                comm_persistence={alone: "permanent"},
                all_clues=True,
            ),
        ),
        (
            f"robot {alone} still isolated",
            observe(
                comm=flags([alone]), links=without([alone]), comm_persistence={alone: "permanent"}
            ),
        ),
        ("every robot blind", observe(sensing=flags(list(range(m))))),
        ("every robot cut off", observe(links=none)),
        ("full zone knowledge, all well again", observe(all_clues=True)),
        ("all well", observe(recoveries=((alone, "comm"),))),
    ]
