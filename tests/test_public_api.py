"""The public top level: what a user needs imports from ``resilient_tracking``, documented.

Every public definition of the package (module-level classes and functions whose names do not
start with ``_``, and the public methods and properties those classes define) has a docstring.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import resilient_tracking

#: Optional parts that need extras (ROS 2 DDS bindings) are walked only if importable.
OPTIONAL = ("resilient_tracking.ros2",)


def test_the_main_names_import_from_the_top_level():
    from resilient_tracking import (  # noqa: F401
        Decision,
        Policy,
        Team,
        TeamObservation,
        check_policy,
        load_scenario,
        make_policy,
        run_episode,
    )


def test_every_exported_name_resolves():
    for name in resilient_tracking.__all__:
        assert getattr(resilient_tracking, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute"):
        resilient_tracking.NotAThing  # noqa: B018


def _modules():
    for info in pkgutil.walk_packages(resilient_tracking.__path__, "resilient_tracking."):
        if info.name.endswith("__main__"):
            continue
        try:
            yield importlib.import_module(info.name)
        except ImportError:
            if not info.name.startswith(OPTIONAL):
                raise


def _undocumented() -> list[str]:
    missing: list[str] = []
    for module in _modules():
        for name, obj in vars(module).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
                continue
            if not (inspect.isclass(obj) or inspect.isfunction(obj)):
                continue
            if not (obj.__doc__ or "").strip() or (
                inspect.isclass(obj) and "__doc__" not in vars(obj)
            ):
                missing.append(f"{module.__name__}.{name}")
            if not inspect.isclass(obj):
                continue
            for attr, member in vars(obj).items():
                if attr.startswith("_"):
                    continue
                func = member.fget if isinstance(member, property) else member
                func = getattr(func, "__func__", func)
                if inspect.isfunction(func) and not (func.__doc__ or "").strip():
                    missing.append(f"{module.__name__}.{name}.{attr}")
    return missing


def test_every_top_level_name_and_its_members_have_a_docstring():
    missing = [
        m
        for m in _undocumented()
        if any(
            m.startswith(f"{getattr(resilient_tracking, n).__module__}.{n}")
            for n in resilient_tracking.__all__[1:]
            if hasattr(getattr(resilient_tracking, n), "__module__")
        )
    ]
    assert not missing, missing


def test_every_public_definition_has_a_docstring():
    missing = _undocumented()
    assert not missing, f"{len(missing)} public definitions without a docstring:\n" + "\n".join(
        missing
    )
