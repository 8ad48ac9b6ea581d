"""Soak (docs/reliability.md), shortened for CI: the soak scenario runs clean with flat memory.

The full run is ``python tools/soak.py`` (2000 steps, memory at 500 and 2000; see
docs/reliability.md). Here ``RTRACK_SOAK_STEPS`` steps (default 24) are run.
"""

from __future__ import annotations

import os

import pytest

from helpers import shipped
from resilient_tracking.sim.soak import soak

pytestmark = pytest.mark.slow

STEPS = int(os.environ.get("RTRACK_SOAK_STEPS", "24"))


def test_the_soak_scenario_is_what_it_says():
    scenario = shipped("soak-20x20")
    assert (len(scenario.robots), len(scenario.targets), len(scenario.zones)) == (20, 20, 6)
    assert scenario.steps == 2000
    kinds = {(z.kind, z.persistence) for z in scenario.zones}
    assert kinds == {
        ("sensing", "temporary"),
        ("sensing", "permanent"),
        ("comm", "temporary"),
        ("comm", "permanent"),
    }


@pytest.mark.soak
def test_soak_runs_clean_with_flat_memory():
    every = max(STEPS // 6, 1)
    report = soak(
        shipped("soak-20x20"), steps=STEPS, checkpoints=(STEPS // 3, STEPS), sample_every=every
    )
    assert report.steps == STEPS
    assert [c.step for c in report.at_checkpoints()] == [STEPS // 3, STEPS]
    assert report.finite, report.non_finite
    assert len(report.samples) >= 6
    assert all(s.cache_weight <= report.cache_budget or s.cached == 1 for s in report.samples)
    assert report.leak_mb() < 2.0
    assert report.samples[-1].peak_rss_mb > 0
