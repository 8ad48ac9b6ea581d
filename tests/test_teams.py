"""Named teams: chosen in a scenario file or by name, filling in what the file leaves unsaid."""

from __future__ import annotations

import pytest
import yaml

from resilient_tracking import builtin_scenarios as scenarios
from resilient_tracking.scenario import Scenario, ScenarioError, load_scenario
from resilient_tracking.scenario.overrides import overridden
from resilient_tracking.scenario.teams import DEFAULT_TEAM, TEAMS, get_team, with_team_settings


def _data(name: str = "sensing-temp") -> dict:
    return yaml.safe_load(scenarios.path(name).read_text())


def test_a_scenario_that_names_no_team_runs_the_default_team():
    scenario = Scenario.parse(_data())
    assert scenario.team == DEFAULT_TEAM
    assert scenario.model_dump() == scenario.with_team(DEFAULT_TEAM).model_dump()


@pytest.mark.parametrize("team", list(TEAMS))
def test_every_team_is_selectable_from_a_scenario_file_and_sets_what_it_says(team):
    data = _data() | {"team": team}
    scenario = Scenario.parse(data, "sensing-temp.yaml")
    assert scenario.team == team
    for path, value in get_team(team).settings.items():
        node = scenario
        for key in path.split("."):
            node = node[key] if isinstance(node, dict) else getattr(node, key)
        assert node == value, path


def test_every_team_fixes_every_setting_the_default_team_changes():
    # so that a team is the same whichever team the scenario it runs on names
    changed = set(get_team(DEFAULT_TEAM).settings)
    for team in TEAMS.values():
        assert changed <= set(team.settings), team.name


def test_the_default_team_prices_caution_with_the_adaptive_estimator_and_route_does_not():
    default = Scenario.parse(_data())
    route = Scenario.parse(_data() | {"team": "route"})
    assert default.estimator.type == "adaptive" and route.estimator.type == "ekf"
    assert default.guards.priced["enabled"] and not route.guards.priced["enabled"]
    assert route.guards.last_sensors["enabled"] and not default.guards.last_sensors["enabled"]


def test_the_paper_team_is_the_one_step_program_without_the_guards():
    paper = Scenario.parse(_data() | {"team": "paper"})
    default = Scenario.parse(_data())
    assert paper.planner.program == "one_step" and default.planner.program == "route"
    assert paper.model_dump() != default.model_dump()


def test_a_scenarios_own_settings_override_its_teams():
    data = _data() | {"team": "paper", "planner": {"program": "route"}}
    scenario = Scenario.parse(data)
    assert scenario.planner.program == "route"
    assert scenario.with_team("default").planner.program == "route"


def test_an_unknown_team_is_an_error_naming_the_field_and_the_teams():
    with pytest.raises(ScenarioError) as err:
        Scenario.parse(_data() | {"team": "papr"}, "mission.yaml")
    message = str(err.value)
    assert (
        "team: unknown team 'papr'" in message and "paper" in message and "mission.yaml" in message
    )


def test_with_team_follows_the_new_team_and_keeps_earlier_overrides():
    base = load_scenario(scenarios.path("sensing-temp"))
    changed = overridden(base.with_overrides(steps=12), {"seed": 3})
    paper = changed.with_team("paper")
    assert (paper.steps, paper.seed, paper.planner.program) == (12, 3, "one_step")
    back = paper.with_team("default")
    assert (back.steps, back.seed, back.planner.program) == (12, 3, "route")


def test_team_settings_fill_only_paths_the_mapping_leaves_unsaid():
    team = get_team("paper")
    data = {"planner": {"program": "route"}, "steps": 5}
    filled = with_team_settings(data, team)
    assert filled["planner"]["program"] == "route"
    assert data == {"planner": {"program": "route"}, "steps": 5}  # the input is not changed
    assert with_team_settings({}, team)["planner"]["program"] == "one_step"


def test_every_team_runs_every_shipped_scenario_file():
    for name in scenarios.names():
        data = _data(name)
        for team in TEAMS:
            Scenario.parse(data | {"team": team}, f"{name}.yaml [{team}]")


def test_rtrack_teams_lists_every_team_with_what_it_fixes(capsys):
    from resilient_tracking.cli import main

    assert main(["teams"]) == 0
    printed = capsys.readouterr().out
    for team in TEAMS.values():
        assert f"{team.name}: {team.summary}" in printed
    assert "    planner.program: one_step" in printed
    assert "    guards.lure.enabled: true" in printed


def test_rtrack_run_takes_a_team_and_settings_by_path(tmp_path):
    import json

    from resilient_tracking.cli import main

    out = tmp_path / "run"
    args = ["run", "sensing-temp", "--steps", "3", "--no-figures", "-q", "--out", str(out)]
    assert main([*args, "--team", "paper", "--set", "guards.lure.enabled=true"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["scenario"]["team"] == "paper"
    assert manifest["scenario"]["planner"]["program"] == "one_step"
    assert manifest["scenario"]["guards"]["lure"] == {"enabled": True}


def test_the_learning_environment_takes_a_team():
    pytest.importorskip("gymnasium")
    from resilient_tracking.env import TeamEnv

    env = TeamEnv("sensing-temp", team="beyond", steps=5)
    scenario = env.session.scenario
    assert scenario.team == "beyond" and scenario.belief.zone_motion.enabled


def test_scenarios_are_equal_by_their_settings_not_by_how_they_were_written():
    written = Scenario.parse(_data() | {"team": "paper"})
    spelled_out = Scenario.parse(written.model_dump(mode="json"))
    assert written == spelled_out and written.own_data() != spelled_out.own_data()
    assert written != written.with_team("default")
