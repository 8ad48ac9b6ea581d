"""The run tables' declaration: recorded tables follow it, and ``docs/run-tables.md`` is
generated from it and up to date."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pandas as pd
import pytest

from helpers import shipped
from resilient_tracking.events import EVENT_NAMES, Event
from resilient_tracking.runs import reference
from resilient_tracking.runs.schema import ALL_TABLES, TABLES
from resilient_tracking.scenario import parse_scenario
from resilient_tracking.sim.episode import run_episode

ROOT = Path(__file__).resolve().parents[1]
STALE = f"is stale: run `{reference.COMMAND}` from the repository's root"


def test_the_run_tables_page_is_the_generated_one():
    page = (ROOT / "docs" / "run-tables.md").read_text()
    assert page == reference.reference(), f"docs/run-tables.md {STALE}"


def test_the_page_names_every_table_and_the_manifest():
    page = reference.reference()
    for table in TABLES.values():
        assert f"## `{table.file}`" in page
    assert "## `manifest.json`" in page


def test_the_readme_points_to_the_run_tables_page():
    assert "docs/run-tables.md" in (ROOT / "README.md").read_text()


def test_every_column_is_described_once():
    for table in TABLES.values():
        assert len(set(table.names)) == len(table.names), table.name
        assert all(c.meaning.strip() for c in table.columns), table.name
        assert set(table.keys) <= set(table.names)


def test_event_fields_are_the_events_columns():
    assert [f.name for f in dataclasses.fields(Event)] == TABLES["events"].names
    assert "attack" in EVENT_NAMES and "solver_fallback" in EVENT_NAMES


def _declared(dtype: str, actual: object) -> bool:
    return str(actual) in (("str", "object") if dtype == "str" else (dtype,))


@pytest.fixture(scope="module")
def recorded() -> dict[str, pd.DataFrame]:
    data = shipped("combined-perm").with_overrides(steps=120).model_dump(mode="json")
    # a zone that moves, so that the zone_tracks table has rows too
    data["zones"][0]["motion"] = {"type": "constant_velocity", "velocity": [0.01, 0.0]}
    return run_episode(parse_scenario(data), seed=7, bound=True).tables


def test_an_episode_records_every_declared_column_with_its_dtype(recorded):
    assert list(recorded) == list(ALL_TABLES)
    for name, df in recorded.items():
        table = TABLES[name]
        assert list(df.columns) == table.names, name
        assert len(df), f"{name} is empty: the check would see no dtype"
        wrong = {c.name: str(df[c.name].dtype) for c in table.columns}
        wrong = {n: d for n, d in wrong.items() if not _declared(table.column(n).dtype, d)}
        assert wrong == {}, name


def test_attack_events_carry_their_facts_as_columns(recorded):
    attacks = recorded["events"].query("event == 'attack'")
    assert len(attacks)
    for row in attacks.itertuples():
        assert row.kind in ("sensing", "comm") and row.zone >= 0
        assert row.persistence in ("temporary", "permanent")
        assert row.cause in ("hazard", "jamming")
        assert row.detail == f"{row.kind} zone{row.zone} {row.persistence} ({row.cause})"
    others = recorded["events"].query("event != 'attack'")
    assert (others["cause"] == "").all()


def test_robots_lost_counts_permanent_attacks_from_the_typed_columns():
    from resilient_tracking.experiments.summary import robots_lost

    events = pd.DataFrame(
        [
            Event.attack(3, 0, "sensing", 1, "permanent", "hazard"),
            Event.attack(4, 1, "comm", 2, "temporary", "jamming"),
            Event.attack(5, 0, "comm", 2, "permanent", "hazard"),
            Event.zone_learned(5, 2, "zone2", "comm", "broadcast", 2, "permanent"),
        ]
    )
    assert robots_lost(events) == 1
    assert robots_lost(events.assign(detail="")) == 1  # the text is not read
    assert robots_lost(events.assign(persistence="permanent")) == 2
