"""Shared fixtures: the shipped scenarios."""

from __future__ import annotations

from pathlib import Path

import pytest

from resilient_tracking.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"


def shipped(name: str) -> Scenario:
    return load_scenario(SCENARIOS / f"{name}.yaml")


@pytest.fixture
def scenario_dir() -> Path:
    return SCENARIOS
