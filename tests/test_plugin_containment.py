"""A plug-in that exits (``sys.exit``) or raises past ``except Exception`` (``GeneratorExit``, its
own ``BaseException``), at import or while running, fails the command with one line naming it
and a non-zero status; it never ends rtrack silently with status 0 nor with a traceback, and
never sees rtrack's command line as its own. Ctrl-C stays an interrupt (docs/reliability.md
§12)."""

from __future__ import annotations

import sys
import sysconfig
import textwrap
import uuid

import pytest
import yaml

from helpers import shipped
from resilient_tracking import plugin_guard
from resilient_tracking.cli import main
from resilient_tracking.policies import POLICIES
from resilient_tracking.registry import UnknownName
from resilient_tracking.scenario import parse_scenario
from resilient_tracking.sim.episode import run_episode

#: A policy whose ``act`` runs ``BODY`` (filled in per test).
POLICY = """
import sys
import numpy as np
from resilient_tracking import Decision, Policy

class Mine(BaseException):
    pass

class P(Policy):
    name = "contained"
    learns_zones = False

    def act(self, belief, obs):
        BODY
        return Decision(np.zeros((obs.n_robots, 2)), ["still"] * obs.n_robots)
"""


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    """Write a module of the given source on the path; its (unique) module name."""
    monkeypatch.syspath_prepend(str(tmp_path))

    def write(source: str) -> str:
        name = f"plug_{uuid.uuid4().hex[:8]}"
        (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))
        return name

    return write


def policy_acting(plugin, body: str) -> str:
    return plugin(POLICY.replace("BODY", body)) + ":P"


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


AT_IMPORT = [
    ("import sys\nsys.exit(0)\n", "called sys.exit(0) at import"),
    ("raise GeneratorExit('gone')\n", "raised GeneratorExit at import: gone"),
    ("class Mine(BaseException):\n    pass\nraise Mine('odd')\n", "raised Mine at import: odd"),
]


@pytest.mark.parametrize(("source", "words"), AT_IMPORT)
def test_a_module_that_exits_at_import_is_an_unknown_name_saying_what_it_did(plugin, source, words):
    name = plugin(source)
    with pytest.raises(UnknownName) as err:
        POLICIES.get(f"{name}:P")
    text = str(err.value)
    assert f"policy '{name}:P': plug-in {name} (" in text and words in text, text
    assert name not in sys.modules


def test_an_entry_point_whose_module_exits_at_import_is_an_unknown_name(plugin, tmp_path):
    name = plugin("import sys\nsys.exit(0)\n")
    info = tmp_path / f"{name}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[resilient_tracking.policies]\n{name} = {name}:P\n")
    with pytest.raises(UnknownName) as err:
        POLICIES.get(name)
    text = str(err.value)
    assert f"entry point '{name}:P': plug-in {name} (" in text, text
    assert "called sys.exit(0) at import" in text


@pytest.mark.parametrize("command", ["run", "validate", "compare"])
def test_a_policy_module_that_exits_at_import_fails_each_command_with_one_line(
    plugin, tmp_path, capsys, command
):
    name = plugin("import sys\nsys.exit(0)\n")
    out = tmp_path / "out"
    if command == "validate":
        data = parse_scenario_data()
        data["policy"] = {"name": f"{name}:P"}
        path = tmp_path / "s.yaml"
        path.write_text(yaml.safe_dump(data))
        assert main(["validate", str(path)]) == 1
        err = capsys.readouterr().err
        assert f"policy.name: policy '{name}:P': plug-in {name} (" in err, err
        assert "called sys.exit(0) at import" in err and "Traceback" not in err
        return
    argv = {
        "run": ["run", "sensing-temp", "--steps", "2", "--policy", f"{name}:P"],
        "compare": ["compare", "sensing-temp", "--seeds", "1", "--policies", f"{name}:P"],
    }[command]
    assert main([*argv, "--out", str(out), "-q"]) == 1
    line = one_error_line(capsys.readouterr().err)
    assert f"plug-in {name} (" in line and "called sys.exit(0) at import" in line, line
    assert not out.exists()


def test_a_target_motion_module_that_exits_at_import_is_a_named_field(plugin):
    name = plugin("import sys\nsys.exit(3)\n")
    data = parse_scenario_data()
    data["targets"][0]["motion"] = {"type": f"{name}:M"}
    with pytest.raises(Exception, match=r"targets\.0\.motion: target motion .*sys\.exit\(3\)"):
        parse_scenario(data)


def test_a_plugin_spec_validator_that_exits_is_one_line_from_the_command(plugin, tmp_path, capsys):
    name = plugin(
        """
        import sys
        from pydantic import field_validator
        from resilient_tracking import MotionSpec, TargetMotion

        class QuitSpec(MotionSpec):
            @field_validator("type")
            @classmethod
            def check(cls, value):
                sys.exit(7)

        class M(TargetMotion):
            Spec = QuitSpec

            def step(self, dt, rng):
                pass
        """
    )
    data = parse_scenario_data()
    data["targets"][0]["motion"] = {"type": f"{name}:M"}
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["validate", str(path)]) == 1
    line = one_error_line(capsys.readouterr().err)
    assert f"plug-in {name}.QuitSpec.check (" in line, line
    assert line.endswith("called sys.exit(7) during rtrack validate")


def test_a_plugin_is_imported_with_its_own_command_line(plugin):
    name = plugin(
        """
        import argparse, sys
        SEEN = list(sys.argv)
        parser = argparse.ArgumentParser()
        parser.add_argument("--flag", action="store_true")
        ARGS = parser.parse_args()
        """
    )
    before = list(sys.argv)
    module = plugin_guard.importing(name)
    seen, args = module.SEEN, module.ARGS
    assert seen == [module.__file__] and not args.flag
    assert sys.argv == before


def test_a_module_whose_parser_exits_at_import_is_one_line_quoting_it(plugin, tmp_path, capsys):
    name = plugin(
        """
        import argparse
        parser = argparse.ArgumentParser(prog="otherprog")
        parser.add_argument("--foo", required=True)
        parser.parse_args()
        """
    )
    out = tmp_path / "out"
    argv = ["run", "sensing-temp", "--steps", "2", "--policy", f"{name}:P", "--out", str(out)]
    assert main(argv) == 1
    printed = capsys.readouterr()
    line = one_error_line(printed.err)
    assert "called sys.exit(2) at import" in line
    assert "it printed: otherprog: error: the following arguments are required: --foo" in line
    assert "usage" not in printed.out + printed.err
    assert not out.exists()


def test_what_a_plugin_prints_at_a_good_import_still_reaches_the_person(plugin, capsys):
    name = plugin("print('hello from the plug-in')\n")
    plugin_guard.importing(name)
    assert capsys.readouterr().out == "hello from the plug-in\n"


def test_an_installed_plugin_is_named_rather_than_the_library_that_exited(capsys):
    """Installed packages may lie inside the standard library's folder: their code is still a
    plug-in's, and the standard library's (argparse, which called sys.exit) is not."""
    file = f"{sysconfig.get_paths()['purelib']}/some_plugin/policy.py"
    code = compile("import argparse\nargparse.ArgumentParser(prog='x').error('no')\n", file, "exec")
    with pytest.raises(plugin_guard.PluginError) as err, plugin_guard.contained("at import"):
        exec(code, {"__name__": "some_plugin.policy"})
    assert (
        str(err.value)
        == f"plug-in some_plugin.policy ({file}, line 2) called sys.exit(2) at import"
    )


RUNNING = [
    ("sys.exit(0)", "called sys.exit(0) while running"),
    ("raise GeneratorExit('gone')", "raised GeneratorExit while running: gone"),
    ("raise Mine('odd')", "raised Mine while running: odd"),
]


@pytest.mark.parametrize(("body", "words"), RUNNING)
def test_a_policy_that_exits_while_running_fails_the_run_naming_its_class(
    plugin, tmp_path, capsys, body, words
):
    policy = policy_acting(plugin, body)
    module = policy.partition(":")[0]
    out = tmp_path / "out"
    argv = ["run", "sensing-temp", "--steps", "2", "--policy", policy, "--no-figures", "-q"]
    assert main([*argv, "--out", str(out)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert f"plug-in {module}.P.act (" in line and words in line, line
    assert "run failed" in line and not out.exists()


def test_a_compare_run_whose_policy_exits_is_a_failed_run_and_no_report(plugin, tmp_path, capsys):
    policy = policy_acting(plugin, "sys.exit(0)")
    out = tmp_path / "out"
    argv = ["compare", "sensing-temp", "--seeds", "1", "--policies", policy, "--set", "steps=2"]
    assert main([*argv, "--jobs", "1", "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "P.act (" in err and "called sys.exit(0) while running" in err, err
    assert "Traceback" not in err and not (out / "report.md").exists()


def test_run_episode_raises_a_plugin_error_and_an_interrupt_stays_one(plugin):
    scenario = parse_scenario({**parse_scenario_data(), "steps": 2})
    with pytest.raises(plugin_guard.PluginError, match="called sys.exit"):
        run_episode(scenario, policy=policy_acting(plugin, "sys.exit(0)"))
    with pytest.raises(KeyboardInterrupt):
        run_episode(scenario, policy=policy_acting(plugin, "raise KeyboardInterrupt"))


def test_an_interrupt_at_import_stays_an_interrupt(plugin):
    name = plugin("raise KeyboardInterrupt\n")
    with pytest.raises(KeyboardInterrupt):
        POLICIES.get(f"{name}:P")


def parse_scenario_data() -> dict:
    data = shipped("sensing-temp").model_dump(mode="json")
    data["steps"] = 2
    return data
