"""What robots receive each tick — the only channel from truth to belief (DESIGN).

The simulator fills these from its world; a real deployment fills them from the robots. They
hold measurements, self-detected failures, attack clues and link states, never zone truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

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
    #: a zone that attacks several capabilities: each kind it attacks with its size (``r``,
    #: ``δ2``); empty for a zone of one kind
    modes: tuple[tuple[FailureKind, float], ...] = ()


@dataclass(frozen=True)
class Attack:
    """An attack a robot felt this tick."""

    robot: int
    clue: ZoneClue
    #: ``hazard`` for a zone's attack draw, ``jamming`` when all its links were cut,
    #: ``degradation`` when the robot's own check found its sensor or radio degraded (an
    #: announced degradation: the capability still works, worse; docs/model.md §2), ``spread``
    #: when a teammate's compromised radio passed the zone's compromise on over a link (the
    #: victim feels it as the zone's attack; the compromise carries the zone's signature).
    cause: Literal["hazard", "jamming", "degradation", "spread"] = "hazard"


@dataclass(frozen=True)
class TeamObservation:
    """One tick of observations for a team of ``M`` robots and ``N`` targets."""

    step: int
    time: float
    #: (M, 2) robot positions (own positions; teammates are observable without radio).
    positions: NDArray[np.float64]
    #: (M, N, D) measurements, D channels of the team's sensor (its ``DIM``; ``[range, bearing]``
    #: for the paper's); NaN where a robot did not measure a target.
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

    @classmethod
    def from_simulator(cls, **fields: Any) -> TeamObservation:
        """An observation the simulator built from its own world, whose fields already have
        the types and shapes :meth:`__post_init__` checks (``tests/test_world.py`` checks that
        they pass): made without checking them again, every tick."""
        obs = cls.__new__(cls)
        obs.__dict__.update(fields)  # what object.__setattr__ per field does, in one call
        return obs

    def __post_init__(self) -> None:
        """Accept lists where arrays are expected; check every shape against the robot count
        ``M`` of ``positions``, naming the field (``ValueError``)."""
        set_ = object.__setattr__
        positions = _array("positions", self.positions, float)
        if positions.ndim != 2 or positions.shape[1] != 2:
            raise ValueError(
                f"TeamObservation.positions: expected shape (M, 2), got {positions.shape}"
            )
        m = positions.shape[0]
        if m < 1:
            raise ValueError("TeamObservation.positions: at least one robot is needed")
        if not np.isfinite(positions).all():
            raise ValueError("TeamObservation.positions: must be finite")
        set_(self, "positions", positions)
        measurements = _array("measurements", self.measurements, float)
        if measurements.ndim != 3 or measurements.shape[0] != m or measurements.shape[2] < 1:
            raise ValueError(
                f"TeamObservation.measurements: expected shape (M={m}, N, D), D the channels of "
                f"the sensor ([range, bearing]: 2), got {measurements.shape}"
            )
        set_(self, "measurements", measurements)
        for name in ("sensing_ok", "comm_ok"):
            flags = _array(name, getattr(self, name), bool)
            if flags.shape != (m,):
                raise ValueError(
                    f"TeamObservation.{name}: expected shape (M={m},), got {flags.shape}"
                )
            set_(self, name, flags)
        for name in ("sensing_persistence", "comm_persistence"):
            values = tuple(getattr(self, name))
            if len(values) != m:
                raise ValueError(f"TeamObservation.{name}: expected {m} entries, got {len(values)}")
            bad = [v for v in values if v not in ("", "temporary", "permanent")]
            if bad:
                raise ValueError(
                    f"TeamObservation.{name}: entries must be '', 'temporary' or 'permanent' "
                    f"(got {bad[0]!r})"
                )
            set_(self, name, values)
        links = _array("links", self.links, bool)
        if links.shape != (m, m):
            raise ValueError(
                f"TeamObservation.links: expected shape (M={m}, M={m}), got {links.shape}"
            )
        if not (links == links.T).all():  # shapes checked above
            raise ValueError("TeamObservation.links: must be symmetric (a link works both ways)")
        set_(self, "links", links)
        attacks = tuple(self.attacks)
        for a in attacks:
            if not isinstance(a, Attack) or not 0 <= a.robot < m:
                raise ValueError(
                    f"TeamObservation.attacks: each must be an Attack on a robot in 0..{m - 1} "
                    f"(got {a!r})"
                )
        set_(self, "attacks", attacks)
        recoveries = tuple((r[0], r[1]) for r in self.recoveries)
        for r in recoveries:
            if not (isinstance(r[0], int | np.integer) and 0 <= r[0] < m) or r[1] not in (
                "sensing",
                "comm",
            ):
                raise ValueError(
                    f"TeamObservation.recoveries: each must be (robot in 0..{m - 1}, "
                    f"'sensing' or 'comm') (got {r!r})"
                )
        set_(self, "recoveries", recoveries)

    @property
    def n_robots(self) -> int:
        """Number of robots ``M``."""
        return int(self.positions.shape[0])

    @property
    def n_targets(self) -> int:
        """Number of targets ``N``."""
        return int(self.measurements.shape[1])

    @property
    def measurement_dim(self) -> int:
        """Channels ``D`` of one measurement (the sensor's ``DIM``)."""
        return int(self.measurements.shape[2])


def _array(name: str, value: object, dtype: type) -> np.ndarray:
    """``value`` as an array of ``dtype`` (lists accepted), or a ``ValueError`` naming it."""
    try:
        out: np.ndarray = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as err:
        raise ValueError(
            f"TeamObservation.{name}: not an array of {dtype.__name__} ({err})"
        ) from None
    return out
