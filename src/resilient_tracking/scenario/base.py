"""Shared pieces of the scenario schema: the size limits a scenario is held to, the plug-in
validator, and (from :mod:`resilient_tracking.spec`) the strict base model and number types."""

from __future__ import annotations

import importlib
from typing import Any

from pydantic import BaseModel, BeforeValidator

from resilient_tracking.spec import (
    MAX_COORDINATE,
    MAX_VARIANCE,
    MIN_VARIANCE,
    Coordinate,
    Matrix2,
    Number,
    PositiveFloat,
    Row2,
    Strict,
    Vec2,
)

__all__ = [
    "MAX_COORDINATE",
    "MAX_DT",
    "MAX_RECORDED_ROWS",
    "MAX_ROBOTS",
    "MAX_ROBOTS_X_TARGETS",
    "MAX_STEPS",
    "MAX_TARGETS",
    "MAX_VARIANCE",
    "MAX_ZONES",
    "MIN_COVARIANCE_RATIO",
    "MIN_DT",
    "MIN_VARIANCE",
    "Coordinate",
    "Matrix2",
    "Number",
    "PositiveFloat",
    "Row2",
    "Strict",
    "Vec2",
    "plugin_spec",
]

#: Smallest eigenvalue ratio λmin/λmax of a covariance: a flatter Σ is numerically singular
#: for the chance constraints and the Mahalanobis tests.
MIN_COVARIANCE_RATIO = 1e-9
#: Upper bounds on sizes: the league NLP grows with robots × targets × zones, so a team beyond
#: these is refused up front rather than left to exhaust memory while the problem is built
#: (a league of more than 20 robots is planned as sub-teams of bounded size, docs/model.md §5.2;
#: 64 × 32 runs in about 300 MB).
MAX_ROBOTS = 64
MAX_TARGETS = 64
MAX_ROBOTS_X_TARGETS = 2048
MAX_ZONES = 32
MAX_STEPS = 100_000
MAX_DT = 10.0
#: at least 1 ms: ``dt`` divides in the velocity bounds and the route pull, and a subnormal one
#: overflows them
MIN_DT = 1e-3
#: Recorded rows (``steps × (robots + targets)``) an episode may hold in memory.
MAX_RECORDED_ROWS = 5_000_000


def plugin_spec(registry: str, tag: str, default: str | None = None) -> Any:
    """A before-validator: the ``Spec`` of the class the mapping's ``tag`` names in the registry
    ``registry`` (``module:ATTRIBUTE``, imported on first use), validated with it, so errors
    name the fields of that ``Spec``. A mapping without ``tag`` names ``default``, if given."""

    def validate(value: Any) -> Any:
        if isinstance(value, BaseModel):
            return value
        if default is not None and isinstance(value, dict) and tag not in value:
            value = {tag: default, **value}
        if not isinstance(value, dict) or not isinstance(value.get(tag), str):
            raise ValueError(f"must be a mapping with a {tag!r} naming the model")
        from resilient_tracking.registry import UnknownName

        module, _, attr = registry.partition(":")
        try:
            cls = getattr(importlib.import_module(module), attr).get(value[tag])
        except UnknownName as err:
            raise ValueError(str(err)) from None
        return cls.Spec.model_validate(value)

    return BeforeValidator(validate)
