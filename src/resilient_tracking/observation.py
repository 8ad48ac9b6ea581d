"""What robots receive each tick — the only channel from truth to belief (DESIGN).

The simulator fills these from its world; a real deployment fills them from the robots. They
hold measurements, self-detected failures, attack clues and link states, never zone truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

FailureKind = Literal["sensing", "comm"]
Persistence = Literal["temporary", "permanent"]


@dataclass(frozen=True)
class ZoneClue:
    """What the victim of an attack learns: the attacking zone's prior (docs/model.md §3)."""

    zone_id: int
    kind: FailureKind
    mu: NDArray[np.float64]
    sigma: NDArray[np.float64]
    #: sensing: the zone radius ``r``; comm: the jamming strength ``δ2``.
    size: float
    persistence: Persistence


@dataclass(frozen=True)
class Attack:
    """An attack a robot felt this tick."""

    robot: int
    clue: ZoneClue
    #: ``hazard`` for a zone's attack draw, ``jamming`` when all its links were cut.
    cause: Literal["hazard", "jamming"] = "hazard"


@dataclass(frozen=True)
class TeamObservation:
    """One tick of observations for a team of ``M`` robots and ``N`` targets."""

    step: int
    time: float
    #: (M, 2) robot positions (own positions; teammates are observable without radio).
    positions: NDArray[np.float64]
    #: (M, N, 2) range/bearing measurements; NaN where a robot did not measure a target.
    measurements: NDArray[np.float64]
    #: (M,) whether each robot's sensor works (a robot knows when its sensor is out).
    sensing_ok: NDArray[np.bool_]
    #: (M,) whether each robot's radio works.
    comm_ok: NDArray[np.bool_]
    #: (M,) persistence of each robot's sensing failure: "" none, "temporary", "permanent".
    sensing_persistence: tuple[str, ...]
    #: (M,) persistence of each robot's comm failure: "" none, "temporary", "permanent".
    comm_persistence: tuple[str, ...]
    #: (M, M) symmetric working-link matrix.
    links: NDArray[np.bool_]
    #: attacks felt since the previous tick
    attacks: tuple[Attack, ...] = field(default_factory=tuple)
    #: robots that recovered since the previous tick: (robot, kind)
    recoveries: tuple[tuple[int, FailureKind], ...] = field(default_factory=tuple)

    @property
    def n_robots(self) -> int:
        return int(self.positions.shape[0])
