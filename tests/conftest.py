"""Shared fixtures: the shipped scenarios."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from resilient_tracking import scenarios
from resilient_tracking.scenario import Scenario, load_scenario

#: Hypothesis profiles for tests that do not fix their own number of examples (the hostile-input
#: properties): "ci" by default, "thorough" for the campaign in docs/reliability.md.
_SLOW_OK = [HealthCheck.too_slow, HealthCheck.data_too_large]
settings.register_profile("ci", max_examples=60, deadline=None, suppress_health_check=_SLOW_OK)
settings.register_profile(
    "thorough", max_examples=2000, deadline=None, suppress_health_check=_SLOW_OK
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = scenarios.folder()


def shipped(name: str) -> Scenario:
    return load_scenario(scenarios.path(name))


@pytest.fixture
def scenario_dir() -> Path:
    return SCENARIOS
