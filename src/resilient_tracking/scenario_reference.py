"""The scenario reference (``docs/scenario-reference.md``), generated from the pydantic schema.

Every field of :class:`~resilient_tracking.scenario.Scenario` and of the models below it is listed
with its type, unit, default, valid range and description, all read from the code, so the
reference cannot drift from what the loader accepts. Regenerate it with::

    python -m resilient_tracking.scenario_reference > docs/scenario-reference.md

``tests/test_scenario_reference.py`` fails when the file is stale or a field has no description.
"""

from __future__ import annotations

import sys
import types
import typing
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Literal, Union, get_args, get_origin

import annotated_types as at
import yaml
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from resilient_tracking.scenario import (
    HazardSpec,
    MotionSpec,
    PolicySpec,
    Scenario,
    SensorSpec,
)
from resilient_tracking.spec import LIMITS


@dataclass(frozen=True)
class Section:
    """One mapping of the format: its dotted path, the model behind it, a variant label."""

    path: str
    model: type[BaseModel]
    variant: str = ""


def _strip(annotation: Any) -> Any:
    """The type under ``Annotated[...]``."""
    while get_origin(annotation) is typing.Annotated:
        annotation = get_args(annotation)[0]
    return annotation


def _is_union(annotation: Any) -> bool:
    return get_origin(annotation) in (Union, types.UnionType)


def _builtin_specs(base: type[BaseModel]) -> list[type[BaseModel]] | None:
    """The ``Spec`` of every built-in of a registry-selected field (sensors, hazard models,
    target motions), in registration order; ``None`` for any other model."""
    if base is SensorSpec:
        from resilient_tracking.models.sensor import SENSORS

        return [SENSORS.get(n).Spec for n in SENSORS.builtin_names()]
    if base is HazardSpec:
        from resilient_tracking.world.hazard_model import HAZARDS

        return [HAZARDS.get(n).Spec for n in HAZARDS.builtin_names()]
    if base is MotionSpec:
        from resilient_tracking.world.target_motion import MOTIONS

        return [MOTIONS.get(n).Spec for n in MOTIONS.builtin_names()]
    return None


def _models(annotation: Any) -> list[type[BaseModel]]:
    """The models a field holds directly, in a list or in a union (``None`` left out); a
    registry-selected field holds the built-in variants."""
    annotation = _strip(annotation)
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return _builtin_specs(annotation) or [annotation]
    if get_origin(annotation) is list:
        return _models(get_args(annotation)[0])
    if _is_union(annotation):
        return [m for arg in get_args(annotation) for m in _models(arg)]
    return []


def type_name(annotation: Any) -> str:
    """Plain words for a field's type as a YAML author sees it."""
    annotation = _strip(annotation)
    origin = get_origin(annotation)
    if _is_union(annotation):
        args = [a for a in get_args(annotation) if a is not type(None)]
        models = _models(annotation)
        if len(models) > 1:
            return "mapping (one of the variants below)"
        text = " or ".join(type_name(a) for a in args)
        return text + (" or null" if len(args) < len(get_args(annotation)) else "")
    if origin is Literal:
        return " \\| ".join(f"`{v}`" for v in get_args(annotation))
    if origin is tuple:
        inner = _strip(get_args(annotation)[0])
        return "2×2 matrix `[[a, b], [c, d]]`" if get_origin(inner) is tuple else "point `[x, y]`"
    if origin is list:
        item = _strip(get_args(annotation)[0])
        if get_origin(item) is tuple:
            return "list of points"
        if get_origin(item) is Literal:
            return f"list of {type_name(item)}"
        return "list of mappings"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        if _builtin_specs(annotation) is not None:
            return "mapping (one of the variants below, or one a package registers)"
        return "mapping"
    if origin is dict:
        return "mapping"
    return {float: "number", int: "integer", str: "string", bool: "bool"}.get(
        annotation, str(annotation)
    )


def _yaml(value: Any) -> str:
    if isinstance(value, BaseModel):
        value = value.model_dump(mode="json")
    if isinstance(value, tuple):
        value = [list(v) if isinstance(v, tuple) else v for v in value]
    return (
        yaml.safe_dump(value, default_flow_style=True, width=10_000, sort_keys=False)
        .strip()
        .removesuffix("\n...")
        .removesuffix(" ...")
    )


def default_text(field: FieldInfo) -> str:
    """A field's default as the reference shows it: ``**required**``, a YAML value, or "see below"
    for a mapping whose default is all its own defaults."""
    if field.is_required():
        return "**required**"
    if field.default_factory is not None:
        return f"`{_yaml(field.default_factory())}`"  # type: ignore[call-arg]
    value = field.default
    if isinstance(value, BaseModel):
        try:
            if type(value)() == value:
                return "see below"
        except ValueError:
            pass
    return f"`{_yaml(value)}`"


def _bounds(annotation: Any) -> list[Any]:
    """The constraints written on a type: ``Annotated`` metadata (``Field(...)`` included), of
    the non-null member of an optional type too."""
    if _is_union(annotation):
        return [m for a in get_args(annotation) if a is not type(None) for m in _bounds(a)]
    if get_origin(annotation) is not typing.Annotated:
        return []
    out: list[Any] = []
    for m in get_args(annotation)[1:]:
        out += m.metadata if isinstance(m, FieldInfo) else [m]
    return out + _bounds(get_args(annotation)[0])


def _bound_words(metadata: list[Any]) -> list[str]:
    parts = []
    for m in metadata:
        for attr, word in (("gt", ">"), ("ge", "≥"), ("lt", "<"), ("le", "≤")):
            if isinstance(m, getattr(at, attr.capitalize())):
                value = getattr(m, attr)
                parts.append(f"{word} {value}" if isinstance(value, int) else f"{word} {value:g}")
        if isinstance(m, at.MinLen):
            parts.append(f"at least {m.min_length} item(s)")
        if isinstance(m, at.MaxLen):
            parts.append(f"at most {m.max_length} items")
    return parts


def range_text(field: FieldInfo) -> str:
    """A field's valid range in words (bounds, list lengths, the bounds of each number of a
    point); empty when it has none."""
    parts = []
    annotation = _strip(field.annotation)
    if get_origin(annotation) is tuple:
        inner = _bound_words(_bounds(get_args(annotation)[0]))
        if inner:
            parts.append(f"each number {', '.join(inner)}")
    return ", ".join(parts + _bound_words(field.metadata + _bounds(field.annotation)))


def unit_text(field: FieldInfo) -> str:
    """A field's unit (its ``unit`` schema extra), else ``–``."""
    extra = field.json_schema_extra
    return str(extra.get("unit", "–")) if isinstance(extra, dict) else "–"


def wraps_own_kind(model: type[BaseModel], field: FieldInfo) -> bool:
    """Whether ``field`` of ``model`` holds a mapping of the model's own kind (an evasive
    target motion's ``base``, itself any target motion): its variants are ``model``'s own."""
    return model in _models(field.annotation)


def sections(model: type[BaseModel] = Scenario, path: str = "") -> Iterator[Section]:
    """Every mapping of the format, depth first, variants of a union one by one (a mapping of
    its parent's own kind is not listed again)."""
    yield Section(path, model)
    for name, field in model.model_fields.items():
        child = f"{path}.{name}" if path else name
        if get_origin(_strip(field.annotation)) is list:
            child += "[]"
        if wraps_own_kind(model, field):
            continue
        models = _models(field.annotation)
        for sub in models:
            if len(models) > 1:
                variant = getattr(sub, "variant", None)  # a variant tagged by more than a Literal
                if variant is None:
                    tag, literal = next(  # the discriminator: a Literal of one value
                        (n, get_args(_strip(f.annotation))[0])
                        for n, f in sub.model_fields.items()
                        if get_origin(_strip(f.annotation)) is Literal
                        and len(get_args(_strip(f.annotation))) == 1
                    )
                    variant = f"{tag}: {literal}"
                for s in sections(sub, child):
                    yield (Section(s.path, s.model, variant) if s.model is sub else s)
            else:
                yield from sections(sub, child)
    if model is PolicySpec:  # each built-in policy's own Params, under its name
        from resilient_tracking.policies import POLICIES

        for name in POLICIES.builtin_names():
            yield from sections(POLICIES.get(name).Params, f"{path}.{name}")


def _table(section: Section) -> str:
    lines = [
        "| field | type | unit | default | valid | meaning |",
        "|---|---|---|---|---|---|",
    ]
    for name, field in section.model.model_fields.items():
        kind = type_name(field.annotation)
        if wraps_own_kind(section.model, field):
            kind = f"mapping (one of the `{section.path}` variants)"
        lines.append(
            f"| `{name}` | {kind} | {unit_text(field)} "
            f"| {default_text(field)} | {range_text(field)} "
            f"| {(field.description or '').replace('|', chr(92) + '|')} |"
        )
    return "\n".join(lines)


def _anchor(path: str, variant: str) -> str:
    """The heading's anchor as MkDocs makes it (lower case, punctuation dropped)."""
    text = f"{path} ({variant})" if variant else path
    keep = "".join(c for c in text.lower() if c.isalnum() or c in " _-")
    return "-".join(keep.split())


def render() -> str:
    """The whole reference page, ``docs/scenario-reference.md``, as Markdown."""
    parts = [
        "# Scenario reference",
        "",
        "Generated from the schema in the `resilient_tracking/scenario/` package by "
        "`python -m resilient_tracking.scenario_reference > docs/scenario-reference.md`; do not "
        "edit by hand. [scenario-format.md](scenario-format.md) explains the format with "
        "examples; the rules there (strict numbers, unknown keys are errors, cross-field "
        "checks) apply to every field below.",
        "",
        "A path such as `zones[].hazard` names a mapping inside every item of a list; a mapping "
        "with variants (`kind`, `type`, `model`) is listed once per variant.",
        "",
        "Every number has bounds (the *valid* column) that keep a run finite, derived from these "
        "limits (`resilient_tracking.spec`); `rtrack validate` names a field outside them. A "
        "circle's speed along its path, `angular_speed` × radius, is held to `MAX_SPEED` too.",
        "",
        "| limit | value | unit | bounds |",
        "|---|---|---|---|",
        *(
            f"| `{n}` | {v if isinstance(v, int) else format(v, 'g')} | {u} | {why} |"
            for n, v, u, why in LIMITS
        ),
        "",
    ]
    seen: dict[tuple[type[BaseModel], str], str] = {}
    listed: set[tuple[type[BaseModel], str, str]] = set()
    for section in sections():
        title = f"`{section.path}`" if section.path else "Top level"
        if section.variant:
            title += f" ({section.variant})"
        doc = (section.model.__doc__ or "").strip().split("\n\n")[0]
        doc = " ".join(doc.split())
        key = (section.model, section.variant)
        if (*key, section.path) in listed:
            continue  # met again under another variant of its parent (a zone's hazard, say)
        listed.add((*key, section.path))
        first = seen.setdefault(key, section.path)
        parts += [f"## {title}", ""]
        if first != section.path:
            parts += [f"The same fields as [`{first}`](#{_anchor(first, section.variant)}).", ""]
            continue
        if doc and section.model is not Scenario:
            parts += [doc, ""]
        parts += [_table(section), ""]
    return "\n".join(parts)


if __name__ == "__main__":
    sys.stdout.write(render())
