"""Truth and belief never touch (DESIGN): belief, planning and policies cannot reach the world."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import numpy as np

import resilient_tracking
from conftest import shipped
from resilient_tracking.sim.episode import run_episode

PACKAGE = Path(resilient_tracking.__file__).parent
BELIEF_SIDE = ("belief", "planning", "policies", "models")
BELIEF_FILES = ("team.py", "team_config.py", "observation.py")


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
    return out


def belief_side_files() -> list[Path]:
    files = [p for d in BELIEF_SIDE for p in (PACKAGE / d).rglob("*.py")]
    return files + [PACKAGE / f for f in BELIEF_FILES]


def test_belief_side_never_imports_world_or_sim():
    offenders = {
        str(p.relative_to(PACKAGE)): sorted(
            m
            for m in imported_modules(p)
            if m.startswith(("resilient_tracking.world", "resilient_tracking.sim"))
        )
        for p in belief_side_files()
    }
    assert len(offenders) > 8  # the scan did find the files
    assert {k: v for k, v in offenders.items() if v} == {}


def test_the_scan_would_catch_an_offender(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("from resilient_tracking.world.zones import TrueZone\n")
    assert "resilient_tracking.world.zones" in imported_modules(bad)


class _Spy:
    """Records every object a policy receives."""

    def __init__(self, policy):
        self.policy = policy
        self.seen: list[object] = []

    def act(self, belief, obs):
        self.seen += [belief, obs, *vars(belief).values(), *vars(obs).values()]
        return self.policy.act(belief, obs)


def test_policy_receives_no_world_object_and_no_true_center(monkeypatch):
    import resilient_tracking.team as team_module

    spies: list[_Spy] = []
    original = team_module.Team.__init__

    def spying_init(self, policy, initial_estimate):
        original(self, policy, initial_estimate)
        spy = _Spy(self.policy)
        spies.append(spy)
        self.policy = spy  # type: ignore[assignment]

    monkeypatch.setattr(team_module.Team, "__init__", spying_init)
    result = run_episode(shipped("sensing-perm").with_overrides(steps=150), seed=1)
    true_centers = result["zones"][["true_x", "true_y"]].to_numpy()
    seen = spies[0].seen
    assert seen
    for obj in seen:
        module = inspect.getmodule(type(obj))
        assert module is None or not module.__name__.startswith("resilient_tracking.world")
    # no array a policy sees holds a drawn true center
    arrays = [o for o in seen if isinstance(o, np.ndarray) and o.dtype.kind == "f"]
    assert arrays
    for arr in arrays:
        values = arr.ravel()
        for cx, cy in true_centers:
            assert not (np.any(values == cx) and np.any(values == cy))
