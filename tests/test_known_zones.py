"""Hazard attacks are counted by whether the attacked robot knew the zone before the attack."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from helpers import shipped
from resilient_tracking.events import Event
from resilient_tracking.experiments.known_zones import hazard_attacks, losses_by_knowledge
from resilient_tracking.experiments.summary import summarise_run
from resilient_tracking.runs.reading import RunData, run_data
from resilient_tracking.sim.episode import run_episode


def _zone(zone: int, kind: str, x: float, y: float) -> dict:
    return {
        "zone": zone,
        "kind": kind,
        "mu_x": x,
        "mu_y": y,
        "sigma_xx": 0.09,
        "sigma_xy": 0.0,
        "sigma_yy": 0.09,
        "size": 0.5,
    }


def _known(step: int, robot: int, zone: int, kind: str, x: float, y: float) -> dict:
    return {"step": step, "robot": robot, "zone": zone, "kind": kind, "x": x, "y": y}


def _run(events: list[Event], knowledge: list[dict], radio_lost: tuple[int, int]) -> RunData:
    """A run of four robots whose sensors and radios work, but robot ``radio_lost[0]``'s radio
    from step ``radio_lost[1]`` on."""
    rows = pd.DataFrame([e.__dict__ for e in events])
    empty = pd.DataFrame()
    robots = pd.DataFrame(
        [
            {
                "step": k,
                "robot": i,
                "sensing_ok": True,
                "comm_ok": not (i == radio_lost[0] and k >= radio_lost[1]),
            }
            for k in range(20)
            for i in range(4)
        ]
    )
    zones = pd.DataFrame([_zone(0, "sensing", 0.0, 0.0), _zone(1, "comm", 3.0, 0.0)])
    return RunData(Path("."), empty, robots, empty, rows, zones, pd.DataFrame(knowledge))


def test_a_loss_counts_as_known_only_if_the_robot_knew_the_zone_before():
    attack = Event.attack
    run = _run(
        [
            attack(10, 0, "sensing", 0, "permanent", "hazard"),  # knew it by id since step 5
            attack(10, 1, "sensing", 0, "permanent", "hazard"),  # learns it in this very step
            attack(12, 2, "comm", 1, "permanent", "hazard"),  # an inferred circle near its mean
            attack(12, 3, "comm", 1, "temporary", "hazard"),  # an inferred zone far away
            attack(13, 0, "comm", 1, "temporary", "jamming"),  # jamming is not a hazard attack
            attack(15, 2, "comm", 1, "permanent", "hazard"),  # its radio is gone: no loss
        ],
        [
            _known(5, 0, 0, "sensing", 0.0, 0.0),
            _known(10, 1, 0, "sensing", 0.0, 0.0),
            _known(8, 2, -1, "comm", 3.4, 0.3),
            _known(8, 3, -1, "comm", 6.0, 0.0),
            _known(8, 3, 0, "sensing", 0.0, 0.0),  # another kind: does not count
        ],
        radio_lost=(2, 12),
    )
    attacks = hazard_attacks(run)
    assert attacks["known"].tolist() == [True, False, True, False, True]
    assert attacks["loss"].tolist() == [True, True, True, True, False]
    assert losses_by_knowledge(run) == {
        "losses_known_permanent": 2,
        "losses_unknown_permanent": 1,
        "losses_known_temporary": 0,
        "losses_unknown_temporary": 1,
    }


def test_a_mapped_zone_that_strikes_is_a_known_one():
    scenario = shipped("sensing-perm").with_overrides(steps=120)
    data = scenario.model_dump()
    data["zones"][0]["known"] = True
    data["zones"][0]["hazard"] = {"model": "gaussian", "kappa": 500.0}  # strikes far out
    known = scenario.parse(data)
    row = summarise_run(run_data(run_episode(known, policy="failure_aware", seed=1)))
    assert row["losses_known_permanent"] >= 1
    assert row["losses_unknown_permanent"] == 0
