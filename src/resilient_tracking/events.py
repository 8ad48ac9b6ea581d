"""Events worth a row in ``events.parquet``: attacks, recoveries, learning, merges, fallbacks."""

from __future__ import annotations

from dataclasses import dataclass

#: ``robot`` value for events that concern a league or the whole team.
TEAM = -1


@dataclass(frozen=True)
class Event:
    step: int
    robot: int
    event: str
    detail: str = ""
