"""Shared pieces of the scenario schema: the strict base model, bounded number types and
the size limits a scenario is held to."""

from __future__ import annotations

import importlib
from typing import Annotated, Any

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
)
from pydantic import Strict as StrictMode

#: Largest magnitude (m, m/s) of a coordinate; beyond it, products of positions overflow.
MAX_COORDINATE = 1e6
#: Largest magnitude (m²) of a covariance entry, and the smallest eigenvalue ratio λmin/λmax: a
#: flatter Σ is numerically singular for the chance constraints and the Mahalanobis tests.
MAX_VARIANCE = 1e12
MIN_COVARIANCE_RATIO = 1e-9
#: Smallest eigenvalue (m²) of a covariance: below it the Gaussian density's normaliser
#: 1/(2π√det Σ) overflows (det Σ underflows to 0 near 1e-300), so the hazard and the risk maps
#: would be NaN. 1e-6 m² is a 1 mm standard deviation, far below any sensor's.
MIN_VARIANCE = 1e-6
#: Upper bounds on sizes: the league NLP grows with robots × targets × zones, so a team beyond
#: these is refused up front rather than left to exhaust memory while the problem is built.
MAX_ROBOTS = 64
MAX_TARGETS = 64
MAX_ROBOTS_X_TARGETS = 1024
MAX_ZONES = 32
MAX_STEPS = 100_000
MAX_DT = 10.0
#: at least 1 ms: ``dt`` divides in the velocity bounds and the route pull, and a subnormal one
#: overflows them
MIN_DT = 1e-3
#: Recorded rows (``steps × (robots + targets)``) an episode may hold in memory.
MAX_RECORDED_ROWS = 5_000_000

#: A number inside a list: strict (an int or a float, never a bool or a string) even where the
#: list itself is lax (``StrictMode(False)`` lets a YAML list stand for a tuple).
Number = Annotated[float, StrictMode()]
#: A coordinate or velocity component: a strict number of bounded size.
Coordinate = Annotated[float, StrictMode(), Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
Vec2 = Annotated[tuple[Coordinate, Coordinate], StrictMode(False)]
Row2 = Annotated[tuple[Number, Number], StrictMode(False)]
Matrix2 = Annotated[tuple[Row2, Row2], StrictMode(False)]
PositiveFloat = Annotated[float, Field(gt=0)]


class Strict(BaseModel):
    """Base: unknown keys are errors, NaN and infinity are rejected, and values are strict.

    Strict mode means a number field takes an int or a float but never a bool (YAML ``yes``) or a
    string (``"0.1"``), a bool field takes only ``true``/``false``, an int field only an integer.
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True, strict=True)


def plugin_spec(registry: str, tag: str) -> Any:
    """A before-validator: the ``Spec`` of the class the mapping's ``tag`` names in the registry
    ``registry`` (``module:ATTRIBUTE``, imported on first use), validated with it, so errors
    name the fields of that ``Spec``."""

    def validate(value: Any) -> Any:
        if isinstance(value, BaseModel):
            return value
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
