"""Changing a scenario by dotted path: ``{"policy.failure_aware.eps1": 0.05, "steps": 20}``.

A path names mapping keys and list indices from the top of the scenario's data (``steps``,
``planner.program``, ``zones.0.hazard.kappa``). Every override of the package goes through
:func:`apply_overrides`: ``Scenario.with_overrides``, ``rtrack compare --set``, the catalogue's
variants and the comparison helpers.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from resilient_tracking.scenario.model import Scenario
from resilient_tracking.scenario.paths import set_path, set_paths

__all__ = [
    "ADVERSARIAL_TEAM",
    "GUARDED_TEAM",
    "BEYOND_TEAM",
    "every_zone_known",
    "PAPER_METHOD",
    "apply_overrides",
    "overridden",
    "set_path",
]

#: The paper's method as written, by dotted path: its one-step program (eq. 9) and its
#: constraint set (eqs. 7c, 7d; none of the failure-aware policy's hazard guard), with the
#: provisional comm zone of a silent teammate at the spread the paper's experiments were
#: reproduced with (docs/model.md §10.1).
PAPER_METHOD: dict[str, Any] = {
    "planner.program": "one_step",
    "policy.failure_aware.hazard_guard": False,
    "policy.failure_aware.silence_std": 0.3,
}

#: The failure-aware team extended for adversarial targets (docs/model.md §4.2), by dotted path:
#: the adaptive estimator, which learns each target's process noise. Without these settings the
#: team is the paper's.
ADVERSARIAL_TEAM: dict[str, Any] = {
    "estimator.type": "adaptive",
}

#: The extended team with the lure guard on as well (docs/model.md §6.1): the defence for
#: scenarios where targets are expected to lure. Not part of the extended team, as it costs
#: trace wherever nothing lures (docs/adversarial.md).
GUARDED_TEAM: dict[str, Any] = ADVERSARIAL_TEAM | {"policy.failure_aware.lure_guard": True}

#: The failure-aware team extended for the world's features beyond the paper (docs/beyond.md),
#: by dotted path: every option of the failure-aware policy for them, in one place. Without
#: these settings the team is the paper's.
BEYOND_TEAM: dict[str, Any] = {
    "policy.failure_aware.quarantine": True,
    "policy.failure_aware.signal_turns": 1.0,
    "policy.failure_aware.degradation_watch.enabled": True,
    "policy.failure_aware.zone_motion.enabled": True,
}


def apply_overrides(data: dict[str, Any], overrides: Mapping[str, Any], source: str) -> Scenario:
    """Set each dotted path of ``overrides`` in the scenario mapping ``data`` (in place), then
    validate it; raises :class:`ScenarioError` from ``source`` naming the dotted path of a field
    that does not exist or of a value the schema refuses."""
    set_paths(data, overrides, source)
    return Scenario.parse(data, source)


def every_zone_known(scenario: Scenario) -> Scenario:
    """``scenario`` with every zone on the team's map from the start (``zones[i].known``)."""
    return overridden(scenario, {f"zones.{i}.known": True for i in range(len(scenario.zones))})


def overridden(
    scenario: Scenario, overrides: Mapping[str, Any], source: str | None = None
) -> Scenario:
    """A validated copy of ``scenario`` with each dotted path of ``overrides`` set (``scenario``
    itself when there are none); errors come from ``source``, by default the scenario's name."""
    if not overrides:
        return scenario
    label = source or f"{scenario.name} (overridden)"
    return apply_overrides(scenario.model_dump(), overrides, label)
