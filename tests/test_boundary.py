"""Truth and belief never touch (DESIGN): belief, planning and policies cannot reach the world."""

from __future__ import annotations

import ast
import inspect
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import resilient_tracking
from helpers import shipped
from resilient_tracking.sim.episode import run_episode

PACKAGE = Path(resilient_tracking.__file__).parent
BELIEF_SIDE = ("belief", "planning", "policies", "models")
BELIEF_FILES = ("team.py", "team_config.py", "observation.py")
#: The code that runs on robots (``world_node.py``, the simulated world over DDS, is not).
ROBOT_NODE_FILES = (
    "ros2/tracker_node.py",
    "ros2/bag.py",
    "ros2/convert.py",
    "ros2/markers.py",
    "ros2/msgs.py",
    "ros2/topics.py",
    "ros2/transport.py",
    "ros2/__init__.py",
)


#: Module prefixes the belief side must never import.
FORBIDDEN_MODULES = ("resilient_tracking.world", "resilient_tracking.sim")
#: Truth classes whose names must not even appear on the belief side (e.g. in type hints).
TRUTH_NAMES = {
    "World",
    "TrueZone",
    "TargetTruth",
    "Failure",
    "GaussianHazardModel",
    "DiskHazardModel",
    "Surroundings",
    "ZoneTruth",
}


def _package_of(path: Path) -> str:
    """Dotted package of a module file under ``src/`` (``resilient_tracking.belief``)."""
    rel = path.resolve().relative_to(PACKAGE.parent.resolve()).with_suffix("")
    parts = list(rel.parts)
    return ".".join(parts[:-1])


def imported_modules(path: Path, package: str | None = None) -> set[str]:
    """Every module a file imports: absolute, relative (resolved), ``from pkg import module``
    (as ``pkg.module``), and string arguments of ``importlib.import_module``/``__import__``."""
    return _imports_in(ast.parse(path.read_text()), _package(path, package))


def _package(path: Path, package: str | None) -> str:
    if package is not None:
        return package
    inside = path.resolve().is_relative_to(PACKAGE.resolve())
    return _package_of(path) if inside else ""


def _imports_in(tree: ast.AST, package: str) -> set[str]:
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                module = ".".join([*base, module] if module else base)
            if module:
                out.add(module)
                out |= {f"{module}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Call):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in ("import_module", "__import__") and node.args:
                arg = node.args[0]
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    out.add(arg.value)
    return out


class _WithoutFunctions(ast.NodeTransformer):
    """Drops function bodies (their imports run only when the function is called) and
    ``if TYPE_CHECKING:`` blocks (never run)."""

    def visit_FunctionDef(self, node: ast.FunctionDef) -> None:
        return None

    def visit_AsyncFunctionDef(self, node: ast.AsyncFunctionDef) -> None:
        return None

    def visit_If(self, node: ast.If) -> ast.AST | None:
        if isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            return None
        return self.generic_visit(node)


def module_level_imports(path: Path, package: str | None = None) -> set[str]:
    """The modules a file imports when it is imported: like :func:`imported_modules`, but not
    looking inside functions."""
    tree = _WithoutFunctions().visit(ast.parse(path.read_text()))
    return _imports_in(tree, _package(path, package))


def module_file(module: str) -> Path | None:
    """The file of a ``resilient_tracking`` module (``None`` for other packages or a name that
    is not a module, such as a class imported with ``from``)."""
    parts = module.split(".")
    if parts[0] != PACKAGE.name:
        return None
    base = PACKAGE.parent.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def imported_at_load(path: Path, package: str | None = None) -> set[str]:
    """Every ``resilient_tracking`` module loaded by importing the file ``path``: its
    module-level imports, the packages above them, and theirs, transitively."""
    found: set[str] = set()
    todo = [(path, package)]
    while todo:
        file, pkg = todo.pop()
        for module in module_level_imports(file, pkg):
            parts = module.split(".")
            for n in range(1, len(parts) + 1):
                name = ".".join(parts[:n])
                target = module_file(name)
                if target is not None and name not in found:
                    found.add(name)
                    todo.append((target, None))
    return found


def truth_names_used(path: Path) -> set[str]:
    """Names of truth classes referenced anywhere in a file (code, hints, strings of hints)."""
    tree = ast.parse(path.read_text())
    hints = [
        hint
        for n in ast.walk(tree)
        for hint in (getattr(n, "annotation", None), getattr(n, "returns", None))
        if isinstance(hint, ast.Constant) and isinstance(hint.value, str)
    ]
    trees = [tree, *(ast.parse(h.value, mode="eval") for h in hints)]
    used = {n.id for t in trees for n in ast.walk(t) if isinstance(n, ast.Name)}
    used |= {n.attr for t in trees for n in ast.walk(t) if isinstance(n, ast.Attribute)}
    return used & TRUTH_NAMES


def belief_side_files() -> list[Path]:
    files = [p for d in BELIEF_SIDE for p in (PACKAGE / d).rglob("*.py")]
    return files + [PACKAGE / f for f in BELIEF_FILES]


def test_belief_side_never_imports_world_or_sim():
    offenders = {
        str(p.relative_to(PACKAGE)): sorted(
            m for m in imported_modules(p) if m.startswith(FORBIDDEN_MODULES)
        )
        for p in belief_side_files()
    }
    assert len(offenders) > 8  # the scan did find the files
    assert {k: v for k, v in offenders.items() if v} == {}


@pytest.mark.parametrize("name", ROBOT_NODE_FILES)
def test_robot_side_node_code_never_loads_the_world(name):
    loaded = imported_at_load(PACKAGE / name)
    assert any(m.startswith("resilient_tracking.runs") for m in loaded) or name != (
        "ros2/tracker_node.py"
    )
    assert sorted(m for m in loaded if m.startswith("resilient_tracking.world")) == []


def test_importing_the_tracker_node_loads_no_world_module():
    pytest.importorskip("cyclonedds")
    code = (
        "import sys, resilient_tracking.ros2.tracker_node\n"
        "print(sorted(m for m in sys.modules if m.startswith('resilient_tracking.')))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = ast.literal_eval(done.stdout.strip().splitlines()[-1])
    assert "resilient_tracking.runs.team_recorder" in loaded  # the scan saw the node's imports
    assert [m for m in loaded if m.startswith("resilient_tracking.world")] == []


def test_the_load_scan_follows_imports_and_skips_functions(tmp_path):
    bad = tmp_path / "node.py"
    bad.write_text("from resilient_tracking.sim.episode import run_episode\n")
    assert "resilient_tracking.world" in imported_at_load(bad, "resilient_tracking.ros2")
    lazy = tmp_path / "lazy.py"
    lazy.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from resilient_tracking.world import World\n"
        "def warm_up():\n    from resilient_tracking.sim.episode import run_episode\n"
    )
    assert imported_at_load(lazy, "resilient_tracking.ros2") == set()


def test_belief_side_never_names_a_truth_class():
    offenders = {str(p.relative_to(PACKAGE)): truth_names_used(p) for p in belief_side_files()}
    assert {k: v for k, v in offenders.items() if v} == {}


@pytest.mark.parametrize(
    ("source", "caught"),
    [
        ("from resilient_tracking.world.zones import TrueZone\n", "resilient_tracking.world.zones"),
        ("import resilient_tracking.world as w\n", "resilient_tracking.world"),
        ("from resilient_tracking import world\n", "resilient_tracking.world"),
        ("from ..world import World\n", "resilient_tracking.world"),
        ("from ..sim.episode import run_episode\n", "resilient_tracking.sim.episode"),
        (
            "import importlib\nm = importlib.import_module('resilient_tracking.world.world')\n",
            "resilient_tracking.world.world",
        ),
    ],
)
def test_the_scan_would_catch_an_offender(tmp_path, source, caught):
    bad = tmp_path / "bad.py"
    bad.write_text(source)
    found = imported_modules(bad, package="resilient_tracking.belief")  # as if in belief/
    assert caught in found
    assert any(m.startswith(FORBIDDEN_MODULES) for m in found)


def test_the_name_scan_would_catch_a_truth_type_hint(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("def f(zone: 'TrueZone', w: world.World) -> None: ...\nx: TargetTruth\n")
    assert truth_names_used(bad) == {"World", "TargetTruth", "TrueZone"}


def reachable(*roots: object, limit: int = 200_000) -> list[object]:
    """Every object reachable from ``roots`` through attributes, containers and dataclass fields
    (numpy arrays are leaves; modules, classes and functions are not followed)."""
    seen: dict[int, object] = {}
    stack = list(roots)
    while stack and len(seen) < limit:
        obj = stack.pop()
        if id(obj) in seen or isinstance(obj, (str, bytes, int, float, bool, type(None))):
            continue
        if inspect.ismodule(obj) or inspect.isclass(obj) or inspect.isroutine(obj):
            continue
        seen[id(obj)] = obj
        if isinstance(obj, np.ndarray):
            if obj.dtype == object:
                stack.extend(obj.ravel().tolist())
            continue
        if isinstance(obj, dict):
            stack.extend(obj.keys())
            stack.extend(obj.values())
        elif isinstance(obj, (list, tuple, set, frozenset)):
            stack.extend(obj)
        if hasattr(obj, "__dict__"):
            stack.extend(vars(obj).values())
        for slot in getattr(type(obj), "__slots__", ()):
            if hasattr(obj, slot):
                stack.append(getattr(obj, slot))
    assert len(seen) < limit, "object graph too large to check"
    return list(seen.values())


def truth_objects(objects: list[object]) -> list[str]:
    """Objects of world or simulator classes, or scenario zone specs (truth's source)."""
    from resilient_tracking.scenario import CommZone, Scenario, SensingZone

    bad = []
    for obj in objects:
        module = getattr(type(obj), "__module__", "") or ""
        if module.startswith(FORBIDDEN_MODULES) or type(obj).__name__ in TRUTH_NAMES:
            bad.append(f"{module}.{type(obj).__name__}")
        elif isinstance(obj, (Scenario, SensingZone, CommZone)):
            bad.append(type(obj).__name__)
    return bad


class _Spy:
    """Records everything a policy receives (deeply), and what the policy holds."""

    def __init__(self, policy):
        self.policy = policy
        self.seen: dict[int, object] = {}
        self.calls = 0

    def act(self, belief, obs):
        self.calls += 1
        if self.calls % 10 == 1:  # every tenth tick is enough and keeps the walk cheap
            for obj in reachable(belief, obs, self.policy):
                self.seen[id(obj)] = obj
        return self.policy.act(belief, obs)


@pytest.fixture
def spies(monkeypatch):
    import resilient_tracking.team as team_module

    found: list[_Spy] = []
    original = team_module.Team.__init__

    def spying_init(self, policy, *args, **kwargs):
        original(self, policy, *args, **kwargs)
        spy = _Spy(self.policy)
        found.append(spy)
        self.policy = spy  # type: ignore[assignment]

    monkeypatch.setattr(team_module.Team, "__init__", spying_init)
    return found


@pytest.mark.parametrize(
    ("name", "policy"),
    [
        ("sensing-perm", "failure_aware"),
        ("comm-perm", "failure_aware"),
        ("combined-temp", "vanilla"),
        ("lure-sensing", "failure_aware"),
    ],
)
def test_policy_receives_no_world_object_and_no_true_center(spies, name, policy):
    result = run_episode(shipped(name).with_overrides(steps=150), policy=policy, seed=1)
    true_centers = result["zones"][["true_x", "true_y"]].to_numpy()
    seen = list(spies[0].seen.values())
    assert spies[0].calls == 150 and len(seen) > 50
    assert truth_objects(seen) == []
    # no array a policy sees holds a drawn true center
    arrays = [o for o in seen if isinstance(o, np.ndarray) and o.dtype.kind == "f"]
    assert arrays
    for arr in arrays:
        values = arr.ravel()
        for cx, cy in true_centers:
            assert not (np.any(values == cx) and np.any(values == cy))


def test_the_runtime_check_would_catch_a_world_object():
    from resilient_tracking.world import World

    world = World(shipped("sensing-perm"), seed=0)
    hidden = {"cache": [(1, world.zones[0])]}  # a true zone two levels down
    assert any("TrueZone" in b for b in truth_objects(reachable(hidden)))
    assert any("Scenario" in b for b in truth_objects(reachable([shipped("sensing-perm")])))


def test_the_learning_agents_view_is_made_on_the_belief_side():
    assert PACKAGE / "belief" / "agent_view.py" in belief_side_files()
    session = (PACKAGE / "env" / "session.py").read_text()
    assert "from resilient_tracking.belief.agent_view import" in session
    # the environment's observations are the views, unchanged
    for name in ("parallel.py", "team.py"):
        source = (PACKAGE / "env" / name).read_text()
        assert "self.session.views()" in source
        assert "world" not in source.replace("world, failure process", "")


@pytest.mark.parametrize(("name", "seed"), [("sensing-perm", 1), ("combined-perm", 2)])
def test_environment_observations_hold_no_truth(monkeypatch, name, seed):
    pytest.importorskip("pettingzoo")
    import resilient_tracking.env.session as session_module
    from resilient_tracking.env import parallel_env

    given: dict[int, object] = {}
    original = session_module.team_views

    def spying_view(belief, obs, *args):
        if obs.step % 10 == 0:
            for obj in reachable(belief, obs):
                given[id(obj)] = obj
        return original(belief, obs, *args)

    monkeypatch.setattr(session_module, "team_views", spying_view)
    env = parallel_env(name, steps=150)
    observations, _ = env.reset(seed=seed)
    seen = [observations]
    true_targets = []
    while env.agents:
        true_targets.append(env.session.running.world.target_states[:, :2].copy())
        observations, *_ = env.step(env.expert_actions())
        seen.append(observations)
    assert len(given) > 50 and truth_objects(list(given.values())) == []
    zones = env.session.result()["zones"]
    assert zones["true_x"].ne(zones["mu_x"]).all()  # drawn centres differ from the priors
    values = np.concatenate(
        [field.ravel() for obs in seen for view in obs.values() for field in view.values()]
    )
    for cx, cy in zones[["true_x", "true_y"]].to_numpy(np.float32):
        assert not (np.any(values == cx) and np.any(values == cy))
    for obs, truth in zip(seen, true_targets, strict=False):  # estimates, never true positions
        for view in obs.values():
            assert not (view["targets"][:, :2] == truth.astype(np.float32)).all(axis=1).any()


def test_the_observation_check_would_catch_a_true_center():
    from resilient_tracking.world import World

    world = World(shipped("sensing-perm"), seed=0)
    cx, cy = world.zones[0].center.astype(np.float32)
    leaked = np.array([1.0, cx, 2.0, cy], dtype=np.float32)
    assert np.any(leaked == cx) and np.any(leaked == cy)
