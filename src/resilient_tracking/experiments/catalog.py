"""The paper's experiments (docs/model.md §8) as data: scenario, variants, seeds.

An :class:`Experiment` names a shipped scenario file (or, for ``generalization``, a generated
suite) and the variants to run on it. A :class:`Variant` is a policy plus overrides of the
scenario by dotted path (``policy.failure_aware.eps1``, ``zones.0.hazard.kappa``…) and, for the
scaling study, how many of the file's robots and targets to keep. Every (variant, seed) pair is
one run.

``quick`` experiments shrink the seed count (and drop grid cells) so that the whole catalogue
runs in a few minutes, as CI does; the claims checked on them are the same.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import yaml

from resilient_tracking import builtin_scenarios
from resilient_tracking.experiments.arms import IN_PLACE_OF, Experiment, Task, Variant, team_arm
from resilient_tracking.experiments.generator import (
    stored_adversarial_suite,
    stored_beyond_suite,
    stored_suite,
)
from resilient_tracking.scenario import Scenario
from resilient_tracking.scenario.effects import SensingDegrade
from resilient_tracking.scenario.overrides import apply_overrides
from resilient_tracking.scenario.teams import get_team


def default_scenario_dir() -> Path:
    """The shipped scenarios (package data, found from any working directory)."""
    return builtin_scenarios.folder()


#: Risk levels of the comparison with SOG (docs/model.md §7): ours ε1 and SOG ρ2 per level.
RISK_LEVELS: dict[str, tuple[float, float]] = {
    "risky": (0.05, 0.6),
    "regular": (0.02, 0.3),
    "conservative": (0.01, 0.2),
}


def scenario_for(
    experiment: Experiment, variant: Variant, scenario_dir: Path | None = None
) -> Scenario:
    """The validated scenario of one variant (raises ``ScenarioError`` naming the field)."""
    path = (scenario_dir or default_scenario_dir()) / f"{experiment.scenario}.yaml"
    data = yaml.safe_load(path.read_text())
    return apply_overrides(data, variant.changes(data), f"{path.name} [{variant.label}]")


def _pair(name: str, seeds: int) -> Experiment:
    return Experiment(
        name=name,
        scenario=name,
        seeds=seeds,
        description="adaptive (failure-aware) vs vanilla",
        variants=(Variant("vanilla", "vanilla"), Variant("failure_aware", "failure_aware")),
        keeps_sensing=name.startswith("combined"),
    )


def _risk_variants() -> tuple[Variant, ...]:
    variants = []
    for level, (eps1, rho2) in RISK_LEVELS.items():
        variants.append(
            Variant(
                f"ours-{level}",
                "failure_aware",
                {"policy.failure_aware.eps1": eps1},
                tags={"method": "ours", "risk": level},
            )
        )
        variants.append(
            Variant(
                f"sog-{level}",
                "sog",
                {"policy.sog.rho2": rho2},
                tags={"method": "sog", "risk": level},
            )
        )
    return tuple(variants)


def _scale_variants(robots: Iterable[int], targets: Iterable[int]) -> tuple[Variant, ...]:
    return tuple(
        Variant(
            f"{method}-r{r}-t{t}",
            policy,
            n_robots=r,
            n_targets=t,
            tags={"method": method, "robots": r, "targets": t},
        )
        for t in targets
        for r in robots
        for method, policy in (("ours", "failure_aware"), ("sog", "sog"))
    )


#: Seeds of each generated scenario: at least two, so that each scenario's comparison has an
#: interval of its per-seed differences (a win, a tie or a loss).
GENERALIZATION_SEEDS = 2
#: The generated suite's size, and the quick (CI) run: its first few small-team scenarios.
SUITE_SIZE = 60
QUICK_SUITE = 2
QUICK_MAX_PAIRS = 16
#: Seeds of the adversarial and beyond experiments in a quick run: their targets are decided by
#: paired intervals, which two seeds leave as wide as no decision, so a quick run only shows
#: that every arm runs and reports (its comparisons are ``short``).
QUICK_BEYOND_PAPER_SEEDS = 1
#: The shipped scenarios of a quick run's adversarial and beyond experiments: one of each kind
#: of claim (an evasive and a luring target; a moving and a degrading zone).
QUICK_ADVERSARIAL = ("evasive-zones", "lure-sensing")
QUICK_BEYOND = ("moving-sensing", "sensing-degrade")


def _sensing_only(scenario: Scenario) -> bool:
    return all(z.kind == "sensing" for z in scenario.zones)


def generalization_cases(
    n: int = SUITE_SIZE, max_pairs: int | None = None
) -> list[tuple[Scenario, tuple[Variant, ...]]]:
    """The first ``n`` scenarios of the generated suite (of those with at most ``max_pairs``
    robot-target pairs, if given, keeping one where SOG runs), each with its arms:
    failure-aware, vanilla, failure-aware with no zones (for the no-zone ratio) and, where every
    zone is a sensing zone, SOG (which models sensing failures only)."""
    scenarios = stored_suite(SUITE_SIZE)
    picked = scenarios[:n]
    if max_pairs is not None:
        small = _small(scenarios, max_pairs)
        picked = small[:n]
        sog_case = next((s for s in small if _sensing_only(s)), None)
        if sog_case is not None and not any(_sensing_only(s) for s in picked):
            picked = picked[: n - 1] + [sog_case]
    out = []
    for scenario in picked:
        arms: list[tuple[str, str, dict[str, Any]]] = [
            ("failure_aware", "failure_aware", {"team": "default"}),
            ("vanilla", "vanilla", {"team": "vanilla"}),
            ("failure_aware-nozone", "failure_aware", {"team": "default", "zones": []}),
        ]
        if _sensing_only(scenario):
            arms.append(("sog", "sog", {"team": "sog"}))
        variants = tuple(
            Variant(
                f"{scenario.name}-{label}",
                policy,
                overrides,
                tags={
                    "scenario": scenario.name,
                    "method": policy,
                    "no_zones": "zones" in overrides,
                },
            )
            for label, policy, overrides in arms
        )
        out.append((scenario, variants))
    return out


#: The shipped scenarios with targets that evade or lure (docs/model.md §1).
ADVERSARIAL = ("evasive-open", "evasive-zones", "lure-sensing", "lure-comm")


#: The teams of the ``adversarial`` experiment: vanilla, the paper's method on the route program
#: with the EKF, and the default team, whose adaptive estimator is on trial (docs/model.md §4.2).
ADVERSARIAL_TEAMS = ("vanilla", "route", "default")

#: Scenarios of the stored adversarial suite in the ``adversarial`` experiment, and the seeds of
#: each (its first ones).
ADVERSARIAL_SUITE_SIZE = 30
ADVERSARIAL_SUITE_SEEDS = 2


def adversarial_cases(
    names: Iterable[str] = ADVERSARIAL,
    suite_size: int = ADVERSARIAL_SUITE_SIZE,
    max_pairs: int | None = None,
    suite_seeds: int = ADVERSARIAL_SUITE_SEEDS,
    scenario_dir: Path | None = None,
) -> list[tuple[Scenario, tuple[Variant, ...]]]:
    """The shipped adversarial scenarios (tagged ``part: shipped``), then the first
    ``suite_size`` scenarios of the stored adversarial suite (of those with at most
    ``max_pairs`` robot-target pairs, if given; tagged ``part: suite``, on their first
    ``suite_seeds`` seeds), each with three arms: the teams ``vanilla``, ``route`` (the
    paper's method with the EKF) and ``default`` (with the adaptive estimator); a shipped
    scenario whose targets lure has a fourth, the team ``guarded`` (with the lure guard). Arms
    are tagged with the scenario and the team."""
    shipped = _shipped(names, scenario_dir)
    generated = _small(stored_adversarial_suite(), max_pairs)[:suite_size]
    cases = _with_three_teams(shipped, generated, ADVERSARIAL_TEAMS, suite_seeds)
    # where a shipped scenario's targets lure, a fourth arm: the team with the lure guard
    return [
        (s, arms + (_arm(s, "guarded", "shipped"),))
        if arms[0].tags["part"] == "shipped" and _lures(s)
        else (s, arms)
        for s, arms in cases
    ]


def _lures(scenario: Scenario) -> bool:
    """Whether a target of ``scenario`` moves as a lure."""
    return any(t.motion.type == "lure" for t in scenario.targets)


#: The shipped scenarios of the world's features beyond the paper (docs/model.md §2).
BEYOND = (
    "moving-sensing",
    "moving-comm-perm",
    "sensing-degrade",
    "comm-degrade",
    "comm-spread",
    "multimodal",
)
#: The teams of the ``beyond`` experiment: vanilla, the default team and the default team with
#: every mechanism for the world's features beyond the paper (docs/beyond.md), on trial.
BEYOND_TEAMS = ("vanilla", "default", "beyond")

#: Seeds of each stored beyond-suite scenario in the ``beyond`` experiment (its first ones).
BEYOND_SUITE_SEEDS = 2


def degrades_sensing(scenario: Scenario) -> bool:
    """Whether a zone of ``scenario`` degrades sensors rather than destroying them."""
    return any(isinstance(getattr(z, "effect", None), SensingDegrade) for z in scenario.zones)


def _three_teams(
    scenario: Scenario, teams: tuple[str, ...], part: str, max_seeds: int | None = None
) -> tuple[Variant, ...]:
    """The ``teams`` on ``scenario``, labelled ``<name>-<team>`` and tagged with the scenario,
    the team, ``part`` and whether a zone degrades sensors (``degrades``)."""
    return tuple(_arm(scenario, team, part, max_seeds) for team in teams)


def _arm(scenario: Scenario, team: str, part: str, max_seeds: int | None = None) -> Variant:
    """The arm of ``team`` on ``scenario``, labelled ``<name>-<team>`` and tagged with the
    scenario, the team, ``part`` and whether a zone degrades sensors."""
    name = scenario.name
    arm = team_arm(team, f"{name}-{team}")
    tags = {"scenario": name, "team": team, "part": part, "degrades": degrades_sensing(scenario)}
    return Variant(arm.label, arm.policy, dict(arm.overrides), tags=tags, max_seeds=max_seeds)


def beyond_cases(
    names: Iterable[str] = BEYOND,
    suite_size: int = SUITE_SIZE,
    max_pairs: int | None = None,
    suite_seeds: int = BEYOND_SUITE_SEEDS,
    scenario_dir: Path | None = None,
) -> list[tuple[Scenario, tuple[Variant, ...]]]:
    """The shipped scenarios of the features beyond the paper (tagged ``part: shipped``), then
    the first ``suite_size`` scenarios of the stored beyond suite (of those with at most
    ``max_pairs`` robot-target pairs, if given; tagged ``part: suite``, on their first
    ``suite_seeds`` seeds), each with three arms: the teams ``vanilla``, ``default`` and
    ``beyond``."""
    shipped = _shipped(names, scenario_dir)
    generated = _small(stored_beyond_suite(), max_pairs)[:suite_size]
    return _with_three_teams(shipped, generated, BEYOND_TEAMS, suite_seeds)


def _shipped(names: Iterable[str], scenario_dir: Path | None) -> list[Scenario]:
    """The shipped scenarios ``names`` (from ``scenario_dir`` if given)."""
    folder = scenario_dir or default_scenario_dir()
    paths = [folder / f"{name}.yaml" for name in names]
    return [Scenario.parse(yaml.safe_load(p.read_text()), p.name) for p in paths]


def _small(scenarios: list[Scenario], max_pairs: int | None) -> list[Scenario]:
    """Those of ``scenarios`` with at most ``max_pairs`` robot-target pairs (all if None)."""
    if max_pairs is None:
        return scenarios
    return [s for s in scenarios if len(s.robots) * len(s.targets) <= max_pairs]


def _with_three_teams(
    shipped: list[Scenario],
    generated: list[Scenario],
    teams: tuple[str, ...],
    suite_seeds: int,
) -> list[tuple[Scenario, tuple[Variant, ...]]]:
    """Each shipped scenario (``part: shipped``) and each generated one (``part: suite``, on its
    first ``suite_seeds`` seeds) with the ``teams`` (:func:`_three_teams`)."""
    return [(s, _three_teams(s, teams, "shipped")) for s in shipped] + [
        (s, _three_teams(s, teams, "suite", suite_seeds)) for s in generated
    ]


SIX = ("sensing-temp", "sensing-perm", "comm-temp", "comm-perm", "combined-temp", "combined-perm")

#: Suffix of the experiments that repeat the paper's on the route program.
ROUTE_SUFFIX = "-route"


def on_program(experiment: Experiment, program: str) -> Experiment:
    """``experiment`` with every arm on one planner program; the route program's copy is named
    with :data:`ROUTE_SUFFIX` and runs the same seeds. On the one-step program every arm is the
    ``paper`` team's (its program, constraint set and settings), so the failure-aware arms run
    the paper's method as written; on the route program they are the ``route`` team's (the
    paper's method with the default guards, the EKF and the paper's fixed risk levels). (SOG
    plans with its own program, so its arms are the same in both.)"""
    settings = (
        dict(get_team("paper").settings)
        if program == "one_step"
        else {"team": "route", "planner.program": program}
    )
    variants = tuple(replace(v, overrides={**v.overrides, **settings}) for v in experiment.variants)
    if program == "one_step":
        return replace(
            experiment,
            variants=variants,
            program=program,
            description=experiment.description + " (the paper's one-step program)",
        )
    return replace(
        experiment,
        name=experiment.name + ROUTE_SUFFIX,
        variants=variants,
        program=program,
        description=experiment.description + " (repeated on the route program, the default)",
    )


def catalog(quick: bool = False) -> dict[str, Experiment]:
    """Every experiment of docs/model.md §8 by name, on the paper's one-step program, then the
    same on the route program, then the generalization benchmark; ``quick`` is the CI size."""
    paper = [_pair(name, 2 if quick else 10) for name in SIX]
    paper += [
        Experiment(
            "bench-risk",
            "bench-risk",
            seeds=2 if quick else 10,
            kind="risk",
            description="4×4, one sensing zone, permanent failures: ours ε1 vs SOG ρ2",
            variants=_risk_variants(),
        ),
        Experiment(
            "bench-scale",
            "bench-scale",
            seeds=1 if quick else 5,
            kind="scale",
            description="robots 2..5 × targets 3..5, two sensing zones: ours vs SOG",
            variants=_scale_variants((2, 5), (3,))
            if quick
            else _scale_variants(range(2, 6), range(3, 6)),
        ),
        Experiment(
            "bench-complex",
            "bench-complex",
            seeds=1 if quick else 5,
            kind="complex",
            description="three sensing zones along the path, 600 steps, three risk levels",
            variants=_risk_variants(),
        ),
    ]
    experiments = [on_program(e, "one_step") for e in paper]
    experiments += [on_program(e, "route") for e in paper]
    experiments += [
        Experiment(
            "generalization",
            "",
            variants=(),
            seeds=GENERALIZATION_SEEDS,
            kind="generalization",
            description=(
                f"{QUICK_SUITE if quick else SUITE_SIZE} generated scenarios "
                f"{'with small teams ' if quick else ''}(docs/generalization.md): "
                "failure-aware vs vanilla, SOG where every zone is a sensing zone, and "
                f"failure-aware without zones for the no-zone ratio ({GENERALIZATION_SEEDS} seeds "
                "each)"
            ),
            generated=partial(generalization_cases, QUICK_SUITE, QUICK_MAX_PAIRS)
            if quick
            else partial(generalization_cases, SUITE_SIZE),
        ),
        Experiment(
            "adversarial",
            "",
            variants=(),
            seeds=QUICK_BEYOND_PAPER_SEEDS if quick else 10,
            kind="adversarial",
            description=(
                "targets that evade or lure (docs/model.md §1): the teams vanilla, route (the "
                "EKF) and default (the adaptive estimator; where targets lure, the team guarded, "
                "with the lure guard, as a fourth arm), on "
                + ", ".join(f"`{n}`" for n in (QUICK_ADVERSARIAL if quick else ADVERSARIAL))
                + f", and on {QUICK_SUITE if quick else ADVERSARIAL_SUITE_SIZE} scenarios of the "
                f"stored adversarial suite{' with small teams' if quick else ''} "
                f"({ADVERSARIAL_SUITE_SEEDS} seeds each)"
            ),
            generated=partial(adversarial_cases, QUICK_ADVERSARIAL, QUICK_SUITE, QUICK_MAX_PAIRS)
            if quick
            else adversarial_cases,
        ),
        Experiment(
            "beyond",
            "",
            variants=(),
            seeds=QUICK_BEYOND_PAPER_SEEDS if quick else 10,
            kind="beyond",
            description=(
                "the world's features beyond the paper (docs/beyond.md): the teams vanilla, "
                "default and beyond on "
                + ", ".join(f"`{n}`" for n in (QUICK_BEYOND if quick else BEYOND))
                + f", and on {QUICK_SUITE if quick else SUITE_SIZE} scenarios of the stored "
                f"beyond suite{' with small teams' if quick else ''} "
                f"({BEYOND_SUITE_SEEDS} seeds each)"
            ),
            generated=partial(beyond_cases, QUICK_BEYOND, QUICK_SUITE, QUICK_MAX_PAIRS, 2)
            if quick
            else beyond_cases,
        ),
    ]
    return {e.name: e for e in experiments}


def select(names: Iterable[str], quick: bool = False) -> list[Experiment]:
    """The experiments named (``all`` for every one); unknown names raise ``KeyError``."""
    known = catalog(quick)
    names = list(names) or ["all"]
    if "all" in names:
        return list(known.values())
    unknown = [n for n in names if n not in known]
    if unknown:
        raise KeyError(f"unknown experiment(s) {unknown}; known: {', '.join(known)}")
    return [known[n] for n in names]


def _generated_arm(scenario: Scenario, variant: Variant) -> Scenario:
    # the scenario's own mapping, so that the arm's team fills in what it leaves unsaid
    data = scenario.own_data()
    return apply_overrides(data, variant.changes(data), f"{scenario.name} [{variant.label}]")


def tasks(
    experiment: Experiment,
    seeds: int | None = None,
    scenario_dir: Path | None = None,
    first_seed: int = 1,
) -> list[Task]:
    """Every run of an experiment, validated before anything runs: ``seeds`` seeds per arm
    (default: the experiment's own number) from ``first_seed`` on."""
    if experiment.generated is not None:
        arms = [
            (variant, _generated_arm(s, variant))
            for s, variants in experiment.generated()
            for variant in variants
        ]
    else:
        arms = [(v, scenario_for(experiment, v, scenario_dir)) for v in experiment.variants]
    return [
        Task(experiment.name, variant, seed, scenario.with_overrides(seed=seed))
        for variant, scenario in arms
        for seed in experiment.seed_list(seeds, first_seed)[: variant.max_seeds]
    ]


def with_policy(runs: list[Task], policy: str) -> list[Task]:
    """``runs`` with the failure-aware planner of their failure-aware arms replaced by the
    policy ``policy`` (``rtrack reproduce --policy``): the arms keep their labels, team and
    belief, so the report's claims judge that policy in the planner's place."""
    return [
        replace(
            t,
            variant=replace(
                t.variant, policy=policy, tags={**t.variant.tags, IN_PLACE_OF: "failure_aware"}
            ),
        )
        if t.variant.policy == "failure_aware"
        else t
        for t in runs
    ]


def with_team(experiment: Experiment, runs: list[Task], team: str) -> list[Task]:
    """``runs`` of ``experiment`` with its own failure-aware arms (the ``route`` team's on the
    route program, the ``default`` team's elsewhere) run by ``team`` instead (``rtrack
    reproduce --team``); the paper's one-step experiments, whose arms are the ``paper`` team's,
    and the arms of other teams are kept."""
    if experiment.program == "one_step":
        return runs
    return [
        replace(t, scenario=t.scenario.with_team(team))
        if t.variant.policy == "failure_aware"
        and t.variant.tags.get("team", "default") == "default"
        else t
        for t in runs
    ]
