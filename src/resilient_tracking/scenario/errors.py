"""Errors of scenario validation, each named by the dotted path of its field."""

from __future__ import annotations

import reprlib
from typing import Any

from pydantic import ValidationError


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


#: Discriminator key of the tagged union held by a field (a list's items for ``zones``), and
#: the variant a mapping without that key is.
_UNION_TAG: dict[str, tuple[str, str | None]] = {
    "zones": ("kind", None),
    "estimator": ("type", "ekf"),
    "effect": ("type", "fail"),
}


def _field_path(loc: tuple[int | str, ...], data: Any) -> str:
    """Dotted path of an error in ``data``, without the union tags pydantic inserts in ``loc``.

    pydantic reports ``zones.0.sensing.sigma`` for a bad ``sigma`` of a sensing zone; the user's
    file has no key ``sensing``, so the tag is dropped: ``zones.0.sigma``. So is the tag of a
    variant the scenario's team chose for a mapping that names none (``estimator.adaptive``).
    """
    parts: list[str] = []
    node, owner = data, None
    for part in loc:
        tag: tuple[str, str | None] | None = (
            _UNION_TAG.get(owner) if isinstance(owner, str) and isinstance(node, dict) else None
        )
        value: Any = node.get(tag[0], tag[1]) if tag is not None else None
        if isinstance(value, list):  # a zone of several kinds: pydantic's tag is "multimodal"
            value = "multimodal"
        # the variant a team filled in for a mapping without the key is not in the file either
        filled = tag is not None and tag[0] not in node and part not in node
        if tag is not None and (value == part or filled):
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


def field_problems(err: ValidationError, data: Any) -> list[str]:
    """One line per error of ``err``: ``field.path: message (got value)``, paths into ``data``."""
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
