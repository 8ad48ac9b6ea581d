"""Changing a scenario by dotted path: ``{"policy.failure_aware.eps1": 0.05, "steps": 20}``.

A path names mapping keys and list indices from the top of the scenario's data (``steps``,
``planner.program``, ``zones.0.hazard.kappa``). Every override of the package goes through
:func:`apply_overrides`: ``Scenario.with_overrides``, ``rtrack compare --set``, the catalogue's
variants and the comparison helpers.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from resilient_tracking.scenario.loading import ScenarioError, parse_scenario, short_repr

if TYPE_CHECKING:
    from resilient_tracking.scenario.model import Scenario


def set_path(data: Any, path: str, value: Any) -> None:
    """Set ``data[a][b][0]…`` from a dotted path ``a.b.0``, creating missing mappings on the way.

    Raises ``IndexError``, ``KeyError`` or ``TypeError`` when a step cannot be taken (an index
    past a list's end, a key into a list or a number)."""
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    for key in keys[:-1]:
        data = data.setdefault(key, {}) if isinstance(data, dict) else data[key]
    data[keys[-1]] = value


def apply_overrides(data: dict[str, Any], overrides: Mapping[str, Any], source: str) -> Scenario:
    """Set each dotted path of ``overrides`` in the scenario mapping ``data`` (in place), then
    validate it; raises :class:`ScenarioError` from ``source`` naming the dotted path of a field
    that does not exist or of a value the schema refuses."""
    problems = []
    for path, value in overrides.items():
        try:
            set_path(data, path, value)
        except (IndexError, KeyError, TypeError):
            problems.append(f"{path}: no such field to set (got {short_repr(value)})")
    if problems:
        raise ScenarioError(source, problems)
    return parse_scenario(data, source)


def overridden(
    scenario: Scenario, overrides: Mapping[str, Any], source: str | None = None
) -> Scenario:
    """A validated copy of ``scenario`` with each dotted path of ``overrides`` set (``scenario``
    itself when there are none); errors come from ``source``, by default the scenario's name."""
    if not overrides:
        return scenario
    label = source or f"{scenario.name} (overridden)"
    return apply_overrides(scenario.model_dump(), overrides, label)
