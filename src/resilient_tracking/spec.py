"""The base of every parameter model: strict pydantic models and bounded number types.

Each component (a policy, the planner, a sensor, a hazard model, a target motion) declares its
own parameters as a model built on :class:`Strict`; the scenario schema
(:mod:`resilient_tracking.scenario`) assembles them. Nothing here knows any component.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field
from pydantic import Strict as StrictMode

#: Largest magnitude (m, m/s) of a coordinate; beyond it, products of positions overflow.
MAX_COORDINATE = 1e6

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
