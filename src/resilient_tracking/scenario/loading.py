"""Loading a scenario: YAML or a mapping in; out, a :class:`Scenario`, or a
:class:`ScenarioError` listing every problem by its field path."""

from __future__ import annotations

import reprlib
from pathlib import Path
from typing import Any

from pydantic import (
    ValidationError,
)

from resilient_tracking.scenario.model import Scenario

# ---------------------------------------------------------------------------- loading


class ScenarioError(ValueError):
    """A scenario file is invalid; ``problems`` lists each one with its field path."""

    def __init__(self, source: str, problems: list[str]):
        self.source = source
        self.problems = problems
        lines = "\n".join(f"  - {p}" for p in problems)
        super().__init__(f"{source}: {len(problems)} problem(s)\n{lines}")


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict = 3, 8, 8
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 60, 60, 40


def short_repr(value: Any, limit: int = 80) -> str:
    """A bounded ``repr``: never renders more than a few items of a large input."""
    text = _REPR.repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


#: Discriminator key of the tagged union held by a field (a list's items for ``zones``).
_UNION_TAG = {"zones": "kind"}


def _field_path(loc: tuple[int | str, ...], data: Any) -> str:
    """Dotted path of an error in ``data``, without the union tags pydantic inserts in ``loc``.

    pydantic reports ``zones.0.sensing.sigma`` for a bad ``sigma`` of a sensing zone; the user's
    file has no key ``sensing``, so the tag is dropped: ``zones.0.sigma``.
    """
    parts: list[str] = []
    node, owner = data, None
    for part in loc:
        tag = _UNION_TAG.get(owner) if isinstance(owner, str) and isinstance(node, dict) else None
        if tag is not None and node.get(tag) == part:
            owner = None
            continue
        parts.append(str(part))
        if isinstance(part, str):
            owner = part
        if isinstance(node, dict):
            node = node.get(part)
        elif isinstance(node, list) and isinstance(part, int) and -len(node) <= part < len(node):
            node = node[part]
        else:
            node = None
    return ".".join(parts) or "<root>"


def _format_pydantic(err: ValidationError, data: Any) -> list[str]:
    out = []
    for e in err.errors():
        loc = e["loc"]
        key = loc[-1] if loc else None
        if e["type"] == "extra_forbidden" and not (isinstance(key, str) and key.isidentifier()):
            # a key that cannot be part of a dotted path: name its mapping, then the key
            path, msg = _field_path(loc[:-1], data), f"unknown key {short_repr(loc[-1], 40)}"
            out.append(f"{path}: {msg} (got {short_repr(e.get('input'))})")
            continue
        path = _field_path(loc, data)
        msg = e["msg"].removeprefix("Value error, ")
        out.append(f"{path}: {msg} (got {short_repr(e.get('input'))})")
    return out


def parse_scenario(data: Any, source: str = "<scenario>") -> Scenario:
    """Validate a parsed mapping; raise :class:`ScenarioError` naming every bad field."""
    if not isinstance(data, dict):
        raise ScenarioError(source, [f"<root>: must be a mapping (got {type(data).__name__})"])
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as err:
        raise ScenarioError(source, _format_pydantic(err, data)) from None
    except RecursionError:
        raise ScenarioError(source, ["<root>: nested too deeply to be a scenario"]) from None
    problems = scenario.problems()
    if problems:
        raise ScenarioError(source, problems)
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a YAML scenario file (bounded: :mod:`resilient_tracking.yaml_io`)."""
    from resilient_tracking.yaml_io import YamlInputError, read_yaml

    try:
        data = read_yaml(path)
    except YamlInputError as err:
        raise ScenarioError(str(path), [str(err)]) from None
    return parse_scenario(data, str(path))
