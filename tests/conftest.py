"""Shared fixtures (helpers shared between test files are in ``helpers.py``)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from helpers import SCENARIOS

#: Hypothesis profiles for tests that do not fix their own number of examples (the hostile-input
#: properties): "ci" by default, "thorough" for the campaign in docs/reliability.md.
_SLOW_OK = [HealthCheck.too_slow, HealthCheck.data_too_large]
settings.register_profile("ci", max_examples=60, deadline=None, suppress_health_check=_SLOW_OK)
settings.register_profile(
    "thorough", max_examples=2000, deadline=None, suppress_health_check=_SLOW_OK
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def scenario_dir() -> Path:
    return SCENARIOS
