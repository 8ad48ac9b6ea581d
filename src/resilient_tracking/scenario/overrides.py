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

__all__ = ["apply_overrides", "every_zone_known", "overridden", "set_path"]


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
    return apply_overrides(scenario.own_data(), overrides, label)
