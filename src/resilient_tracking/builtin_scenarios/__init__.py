"""The scenarios shipped with the package: the paper's six, the three benchmarks, a soak run,
``swarm-40x20`` (40 robots, planned as sub-teams),
``bearing-only`` (the sensing-temp mission with a bearing-only sensor), four with targets
that react to the world: ``evasive-open``, ``evasive-zones``, ``lure-sensing`` and ``lure-comm``,
two whose zones degrade instead of disabling: ``sensing-degrade`` and ``comm-degrade``,
``comm-spread`` (a permanent comm zone whose compromise spreads over links), two with a moving
zone: ``moving-sensing`` and ``moving-comm-perm``, ``multimodal``, one zone attacking both
the sensor and the radio, and ``ncv-sensing``, whose targets move by the estimator's own
nearly-constant-velocity model (so the posterior Cramér–Rao bound is a true bound there).

They are package data, so they are found the same way from a checkout, an editable install or
a wheel, whatever the working directory. Every command that takes a scenario accepts either a
path to a YAML file or the name of a shipped scenario (``sensing-temp``).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from resilient_tracking.scenario import Scenario, ScenarioError, load_scenario

SUFFIX = ".yaml"


def folder() -> Path:
    """The folder holding the shipped scenario files."""
    # A regular (unzipped) install: the package folder is a real directory.
    return Path(str(resources.files(__name__)))


def names() -> list[str]:
    """Names of the shipped scenarios, sorted."""
    return sorted(p.name.removesuffix(SUFFIX) for p in folder().glob(f"*{SUFFIX}"))


def path(name: str) -> Path:
    """The file of a shipped scenario; ``KeyError`` naming the known ones if there is none."""
    file = folder() / f"{name}{SUFFIX}"
    if not file.is_file():
        raise KeyError(f"no shipped scenario {name!r}; shipped: {', '.join(names())}")
    return file


def resolve(name_or_path: str | Path) -> Path:
    """A path to an existing file as given, else the shipped scenario of that name.

    Raises :class:`ScenarioError` (naming the argument) when it is neither.
    """
    given = Path(name_or_path)
    if given.exists() or given.suffix.lower() in (".yaml", ".yml") or len(given.parts) > 1:
        return given
    if str(name_or_path) in names():
        return path(str(name_or_path))
    raise ScenarioError(
        str(name_or_path),
        [f"<scenario>: neither a file nor a shipped scenario (shipped: {', '.join(names())})"],
    )


def load(name_or_path: str | Path) -> Scenario:
    """Load and validate a scenario given by path or by shipped name."""
    return load_scenario(resolve(name_or_path))
