"""Loading a scenario: YAML or a mapping in; out, a :class:`Scenario`, or a
:class:`ScenarioError` listing every problem by its field path."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from resilient_tracking.scenario.errors import ScenarioError
from resilient_tracking.scenario.model import Scenario

__all__ = ["ScenarioError", "load_scenario", "parse_scenario"]


def parse_scenario(data: Any, source: str = "<scenario>") -> Scenario:
    """Validate a parsed mapping; raise :class:`ScenarioError` naming every bad field."""
    return Scenario.parse(data, source)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a YAML scenario file (bounded: :mod:`resilient_tracking.yaml_io`)."""
    from resilient_tracking.yaml_io import YamlInputError, read_yaml

    try:
        data = read_yaml(path)
    except YamlInputError as err:
        raise ScenarioError(str(path), [str(err)]) from None
    return parse_scenario(data, str(path))
