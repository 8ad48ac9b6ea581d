"""The shapes of ``rtrack reproduce``'s work: an experiment, its arms (variants) and the runs
(tasks) they make, and the arm of a named team."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from resilient_tracking.build import policy_files_digest
from resilient_tracking.runs.folders import folder_name
from resilient_tracking.runs.manifest import code_digest
from resilient_tracking.scenario import Scenario
from resilient_tracking.scenario.teams import get_team

#: The tag of an arm whose policy runs in another's place (``rtrack reproduce --policy``): the
#: policy it stands for, whose claims judge it.
IN_PLACE_OF = "in_place_of"


@dataclass(frozen=True)
class Variant:
    """One arm of an experiment: a policy and how the scenario file is changed for it."""

    label: str
    policy: str
    overrides: Mapping[str, Any] = field(default_factory=dict)
    n_robots: int | None = None
    n_targets: int | None = None
    #: free-form attributes used to group runs in figures and claims (risk level, team size)
    tags: Mapping[str, Any] = field(default_factory=dict)
    #: at most this many of the experiment's seeds (its first ones) for this arm; None: all
    max_seeds: int | None = None

    def changes(self, data: Mapping[str, Any]) -> dict[str, Any]:
        """Everything this arm changes in the scenario mapping ``data``, by dotted path: the
        team and targets cut to size, the policy, then :attr:`overrides`."""
        changes: dict[str, Any] = {}
        if self.n_robots is not None:
            changes["robots"] = data["robots"][: self.n_robots]
        if self.n_targets is not None:
            changes["targets"] = data["targets"][: self.n_targets]
        changes["policy.name"] = self.policy
        return {**changes, **self.overrides}


@dataclass(frozen=True)
class Experiment:
    """One experiment of ``rtrack reproduce``: a scenario (or generated ones), its variants, how
    many seeds, and which figures and claims its report section draws."""

    name: str
    scenario: str  # name of a shipped scenario (``resilient_tracking.builtin_scenarios``)
    variants: tuple[Variant, ...]
    seeds: int
    description: str = ""
    #: figures and claims to draw from it: "pair", "risk", "scale", "complex" or
    #: "generalization"
    kind: str = "pair"
    #: generated scenarios instead of a file: returns (scenario, its variants) pairs, and
    #: ``scenario`` and ``variants`` above are unused
    generated: Callable[[], list[tuple[Scenario, tuple[Variant, ...]]]] | None = None
    #: the planner program its runs use ("one_step": the paper's; "route": the default;
    #: "": the scenarios' own setting)
    program: str = ""
    #: whether the paper's narrative of it has a robot sensing to the end (the combined
    #: scenarios: "R1 avoids entering the danger zones and continues to support the team's
    #: tracking efforts"), checked as a claim
    keeps_sensing: bool = False

    def seed_list(self, n: int | None = None, first: int = 1) -> list[int]:
        """``n`` seeds from ``first`` on (default ``n``: the experiment's own number of
        seeds; ``first`` other than 1 checks the claims on seeds none of them was made on)."""
        return list(range(first, first + (n or self.seeds)))


@dataclass(frozen=True)
class Task:
    """One run of a sweep: a fully validated scenario, a policy and a seed; ``bound``: the run
    also computes the posterior Cramér–Rao bound."""

    experiment: str
    variant: Variant
    seed: int
    scenario: Scenario
    bound: bool = False

    @property
    def run_id(self) -> str:
        """The run's path under ``OUT/runs``: ``experiment/variant/seed-NNN``."""
        return (
            f"{folder_name(self.experiment)}/{folder_name(self.variant.label)}/seed-{self.seed:03d}"
        )

    @property
    def fingerprint(self) -> str:
        """Hash of everything that determines the run's tables: the scenario, the policy, the
        seed, whether the bound is computed, and the package's code
        (:func:`~resilient_tracking.runs.manifest.code_digest`) and the files the policy reads
        (an ONNX model's weights, :func:`~resilient_tracking.build.policy_files_digest`); a
        stored run with another fingerprint is stale and is run again. The free-text
        ``description`` is left out: rewording it changes no result."""
        text = json.dumps(
            [
                self.scenario.model_dump(mode="json", exclude={"description"}),
                self.variant.policy,
                *filter(None, [policy_files_digest(self.variant.policy, self.scenario)]),
                self.seed,
                *(["bound"] if self.bound else []),
                code_digest(),
            ],
            sort_keys=True,
        )
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def team_arm(team: str, label: str | None = None, over_file: bool = False, **tags: Any) -> Variant:
    """The arm of the named team ``team``: its policy, and the team filling in every setting
    the scenario leaves unsaid (as ``team:`` in a scenario file does), labelled ``label``
    (default: the team). ``over_file``: the team's settings replace what the file says too,
    as the paper's experiments run team ``paper`` on its one-step program whatever program a
    file names."""
    settings = get_team(team).settings
    policy = settings.get("policy.name", "failure_aware")
    overrides = dict(settings) if over_file else {"team": team}
    return Variant(label or team, policy, overrides, tags={"team": team, **tags})
