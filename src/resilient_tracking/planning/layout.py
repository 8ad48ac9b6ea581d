"""The league problem's layout: its sizes, its per-step inputs by name, and where each input
and decision variable sits in the solver's flat vectors.

Every per-step number of a league problem is a field of :class:`ProblemInputs`. A field that is
a parameter of the NLP says so with :func:`parameter`: how many numbers it has per robot, per
target, per known zone or once per problem. :class:`ParameterLayout` packs the numeric values
(:meth:`ParameterLayout.pack`) and makes the matching CasADi symbols
(:meth:`ParameterLayout.symbols`) in the order of the fields, so a new per-robot input (a route
waypoint, a cost-to-go weight) is one new field here and one use in the NLP::

    waypoints: np.ndarray | None = field(default=None, metadata=parameter("robot", 2, "waypoint"))

(an input left at None is packed as zeros; ``LeagueNLP`` reads the symbol as
``self.params["waypoints"]``, a ``2 × n`` SX).

Zone rows and weights are tables whose columns are named by :class:`SensingRow`,
:class:`CommRow` and :class:`Weight`; nothing outside this module indexes them by number.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.models.sensor import PLAN_EPS, MeasurementModel

# ---------------------------------------------------------------------------- named columns


class SensingRow:
    """Columns of a sensing-zone row (eq. 7c): the zone estimate's mean and covariance, the
    keep-out radius ``r_safe`` and the chance margin ``β1``."""

    MEAN = slice(0, 2)
    #: covariance entries xx, xy, yy
    COVARIANCE = slice(2, 5)
    #: mean and covariance entries xx, xy, yy: what the keep-out margin needs of a zone
    GAUSSIAN = slice(0, 5)
    R_SAFE = 5
    BETA = 6
    WIDTH = 7


class CommRow:
    """Columns of a comm-zone row (eq. 7d): the zone estimate's mean and covariance, the
    jamming ratio ``δ2``, the chance margin ``β2`` and an extra clearance (0 for a zone known
    from an attack clue; set for a zone inferred from a circling robot)."""

    MEAN = slice(0, 2)
    COVARIANCE = slice(2, 5)
    GAUSSIAN = slice(0, 5)
    DELTA2 = 5
    BETA = 6
    CLEARANCE = 7
    WIDTH = 8


class RouteRow:
    """Columns of a robot's route row (the route program's cost-to-go,
    :mod:`~resilient_tracking.planning.goals`): the route's next waypoint, the route length left
    after it minus the reach, and the pull's weight."""

    WAYPOINT = slice(0, 2)
    OFFSET = 2
    WEIGHT = 3
    WIDTH = 4


class Weight:
    """Entries of the objective's weight vector (eq. 6): tracking, effort, sensing-zone
    slacks, comm-zone slacks."""

    TRACKING = 0
    EFFORT = 1
    SENSING_SLACK = 2
    COMM_SLACK = 3
    COUNT = 4


def _covariance_entries(cov: np.ndarray) -> list[float]:
    return [float(cov[0, 0]), float(cov[0, 1]), float(cov[1, 1])]


def sensing_row(mean: ArrayLike, cov: np.ndarray, r_safe: float, beta: float) -> list[float]:
    """One :class:`SensingRow`."""
    return [*np.asarray(mean, dtype=float), *_covariance_entries(cov), r_safe, beta]


def comm_row(
    mean: ArrayLike, cov: np.ndarray, delta2: float, beta: float, clearance: float
) -> list[float]:
    """One :class:`CommRow`."""
    return [*np.asarray(mean, dtype=float), *_covariance_entries(cov), delta2, beta, clearance]


def sensing_table(rows: Sequence[Sequence[float]] = ()) -> np.ndarray:
    """``(L, SensingRow.WIDTH)`` from rows (none: an empty table)."""
    return np.array(rows, dtype=float).reshape(-1, SensingRow.WIDTH)


def comm_table(rows: Sequence[Sequence[float]] = ()) -> np.ndarray:
    """``(K, CommRow.WIDTH)`` from rows (none: an empty table)."""
    return np.array(rows, dtype=float).reshape(-1, CommRow.WIDTH)


# ---------------------------------------------------------------------------- sizes


@dataclass(frozen=True)
class Structure:
    """What changes the symbolic problem: sizes, and the planner program.

    ``route`` adds the route program's cost-to-go (one :class:`RouteRow` per robot);
    ``standoff`` is the distance regularisation (m) of the information model,
    :data:`~resilient_tracking.models.sensor.PLAN_EPS` in the paper's one-step program;
    ``sensor_model`` is the robots' measurement model, whose information the tracking term
    uses (a new sensor is a new :class:`MeasurementModel` subclass).
    """

    n_robots: int
    n_targets: int
    n_sensing_zones: int = 0
    n_comm_zones: int = 0
    route: bool = False
    standoff: float = PLAN_EPS
    sensor_model: type[MeasurementModel] = RangeBearingSensor

    @property
    def label(self) -> str:
        """A short name for compiled code and logs."""
        sizes = f"{self.n_robots}x{self.n_targets}_{self.n_sensing_zones}s{self.n_comm_zones}c"
        route = f"_route{round(self.standoff * 1000)}mm" if self.route else ""
        sensor = "" if self.sensor_model is RangeBearingSensor else f"_{self.sensor_model.__name__}"
        return f"league_{sizes}{route}{sensor}"

    @property
    def n_vars(self) -> int:
        """Decision variables: per robot a velocity ``u_i`` (2) and one slack per sensing and per
        comm zone."""
        return self.n_robots * (2 + self.n_sensing_zones + self.n_comm_zones)

    @property
    def n_constraints(self) -> int:
        """Constraint rows: per robot one per sensing zone (eq. 7c) and one per comm zone and
        teammate (eq. 7d)."""
        n = self.n_robots
        return n * self.n_sensing_zones + n * self.n_comm_zones * (n - 1)

    def count(self, per: str) -> int:
        """How many items of a :func:`parameter`'s ``per`` the problem has."""
        return {
            "robot": self.n_robots,
            "target": self.n_targets,
            "sensing_zone": self.n_sensing_zones,
            "comm_zone": self.n_comm_zones,
            "problem": 1,
        }[per]


@dataclass(frozen=True)
class Slots:
    """Sizes of the SQP's reduced problem (:mod:`~resilient_tracking.planning.reduction`):
    per robot, ``sensing`` sensing-zone rows, ``comm`` comm-zone slacks with ``mates``
    teammate rows each; which zone and teammate fill each slot is a parameter."""

    sensing: int
    comm: int
    mates: int


# ---------------------------------------------------------------------------- inputs


def parameter(
    per: str,
    size: int | Callable[[Structure], int],
    symbol: str,
    columns: Callable[[Any], Any] | None = None,
    when: str = "",
) -> dict[str, Any]:
    """Field metadata of a :class:`ProblemInputs` field that is an NLP parameter: ``size``
    numbers (or a function of the :class:`Structure` giving it) ``per`` robot, target,
    sensing_zone, comm_zone or problem, as CasADi symbol ``symbol`` of shape
    ``(size, count)``. ``columns`` turns the numeric value into ``(count, size)`` (default:
    the value itself, reshaped). ``when`` names a :class:`Structure` flag: the parameter
    exists only in problems that have it set."""
    return {"parameter": (per, size, symbol, columns, when)}


def _information_entries(info: np.ndarray) -> np.ndarray:
    """``(N, 2, 2)`` symmetric matrices as ``(N, 3)`` entries xx, xy, yy."""
    return np.stack([info[:, 0, 0], info[:, 0, 1], info[:, 1, 1]], axis=1)


@dataclass
class ZoneNeeds:
    """Which zone rows can bind this step (:func:`~.reduction.zone_needs`), and the teammate
    distance bounds they were judged with."""

    #: (n, L) and (n, K): robot i may need sensing zone l's row, comm zone k's rows
    sensing: np.ndarray
    comm: np.ndarray
    #: (n, n) lower and upper bounds of the teammates' distance after the step (−∞ on the
    #: diagonal and for links left out of eq. 7d)
    near: np.ndarray
    far: np.ndarray


@dataclass
class ProblemInputs:
    """Numeric values for one solve of a league problem."""

    #: (n, 2) robot positions
    positions: np.ndarray = field(metadata=parameter("robot", 2, "x"))
    #: (n,) 1.0 if the robot can sense
    sensing: np.ndarray = field(metadata=parameter("robot", 1, "s"))
    #: (N, 2) predicted target positions at t+1
    targets: np.ndarray = field(metadata=parameter("target", 2, "targets"))
    #: (N, 2, 2) predicted position-block information P⁻¹
    prior_info: np.ndarray = field(metadata=parameter("target", 3, "prior", _information_entries))
    #: (4,) w1..w4, entries named by :class:`Weight`
    weights: np.ndarray = field(metadata=parameter("problem", Weight.COUNT, "w"))
    #: the sensor model's parameters (``MeasurementModel.parameters``)
    sensor: np.ndarray = field(
        metadata=parameter("problem", lambda s: s.sensor_model.N_PARAMETERS, "sensor")
    )
    dt: float = field(metadata=parameter("problem", 1, "dt"))
    #: (n, 2) velocity bounds
    u_lower: np.ndarray
    u_upper: np.ndarray
    #: (L, SensingRow.WIDTH) known sensing zones
    sensing_zones: np.ndarray = field(
        metadata=parameter("sensing_zone", SensingRow.WIDTH, "szones")
    )
    #: (K, CommRow.WIDTH) known comm zones
    comm_zones: np.ndarray = field(metadata=parameter("comm_zone", CommRow.WIDTH, "czones"))
    #: (n, RouteRow.WIDTH) the route program's cost-to-go rows; None for the one-step program
    route: np.ndarray | None = field(
        default=None, metadata=parameter("robot", RouteRow.WIDTH, "route", when="route")
    )
    #: (n, n) the route program's eq. 7d links: 1 where the pair's jamming row is left out
    #: (the league keeps a spanning tree of its links, :func:`~.spanning.spanning_unlinked`); None
    #: (zeros): every teammate, the paper's rule
    unlinked: np.ndarray | None = field(
        default=None,
        metadata=parameter("robot", lambda s: s.n_robots, "unlinked", when="route"),
    )
    #: distance regularisation (m) of the information model (:attr:`Structure.standoff`)
    standoff: float = PLAN_EPS
    #: the robots' measurement model (:attr:`Structure.sensor_model`)
    sensor_model: type[MeasurementModel] = RangeBearingSensor
    #: which zone rows can bind, when whoever made these inputs has already judged it (the
    #: sub-team windows); never copied by :func:`dataclasses.replace`, whose inputs may differ
    zone_needs: ZoneNeeds | None = field(default=None, init=False, repr=False, compare=False)

    def structure(self) -> Structure:
        """The sizes and program of the problem these inputs are for."""
        return Structure(
            n_robots=len(self.positions),
            n_targets=len(self.targets),
            n_sensing_zones=len(self.sensing_zones),
            n_comm_zones=len(self.comm_zones),
            route=self.route is not None,
            standoff=self.standoff,
            sensor_model=self.sensor_model,
        )


@dataclass(frozen=True)
class Parameter:
    """One block of the NLP's parameter vector."""

    name: str  # the ProblemInputs field
    per: str
    size: int | Callable[[Structure], int]
    symbol: str
    columns: Callable[[Any], Any] | None
    #: the Structure flag the parameter depends on ("": always there)
    when: str

    def present(self, structure: Structure) -> bool:
        """Whether the block is in the parameter vector of ``structure`` (its ``when`` flag is
        set, or it has none)."""
        return not self.when or bool(getattr(structure, self.when))

    def size_in(self, structure: Structure) -> int:
        """Numbers per item (robot, target, zone...) in ``structure``."""
        return self.size(structure) if callable(self.size) else self.size


#: The NLP's parameters in packing order: the :func:`parameter` fields of ProblemInputs.
PARAMETERS: tuple[Parameter, ...] = tuple(
    Parameter(f.name, *f.metadata["parameter"])
    for f in fields(ProblemInputs)
    if "parameter" in f.metadata
)


class ParameterLayout:
    """The flat parameter vector ``p`` of a league NLP of ``structure``: the
    :data:`PARAMETERS` blocks, each ``(size, count)`` column by column, then, for the SQP's
    reduced problem (``slots``), its one-hot selections of zones and teammates."""

    def __init__(self, structure: Structure, slots: Slots | None = None):
        self.structure = structure
        self.slots = slots

    def symbols(self) -> dict[str, Any]:
        """CasADi SX symbols by field name (and ``ssel``, ``csel``, ``msel`` with slots)."""
        s = self.structure
        out = {
            block.name: ca.SX.sym(block.symbol, block.size_in(s), s.count(block.per))
            for block in PARAMETERS
            if block.present(s)
        }
        if self.slots:
            # one-hot (or, for an unused slot, zero) columns: slot s of robot i is column
            # i·S + s; teammates are numbered without robot i
            n, slots = s.n_robots, self.slots
            out["ssel"] = ca.SX.sym("ssel", s.n_sensing_zones, n * slots.sensing)
            out["csel"] = ca.SX.sym("csel", s.n_comm_zones, n * slots.comm)
            out["msel"] = ca.SX.sym("msel", n - 1, n * slots.mates)
        return out

    @staticmethod
    def pack(q: ProblemInputs) -> np.ndarray:
        """The numeric parameter vector of ``q`` (without any slot selections)."""
        parts = []
        structure = q.structure()
        for block in PARAMETERS:
            if not block.present(structure):
                continue
            value = getattr(q, block.name)
            if value is None:  # an optional input left out: zeros
                value = np.zeros((structure.count(block.per), block.size_in(structure)))
            elif block.columns is not None:
                value = block.columns(value)
            size = block.size_in(structure)
            parts.append(np.asarray(value, dtype=float).reshape(-1, size).ravel())
        return np.concatenate(parts)


@dataclass(frozen=True)
class VariableLayout:
    """Where each decision variable sits in ``x = (u, ν, ξ)``: the velocities ``u_i`` of
    every robot, then ``n_nu`` sensing slacks per robot, then ``n_xi`` comm slacks per robot.
    Works on integers and on NumPy index arrays alike."""

    n_robots: int
    n_nu: int
    n_xi: int

    @property
    def n_u(self) -> int:
        """Number of velocity entries, ``2 n``."""
        return 2 * self.n_robots

    @property
    def n_vars(self) -> int:
        """Length of the decision vector ``x = (u, ν, ξ)``."""
        return self.n_robots * (2 + self.n_nu + self.n_xi)

    def u(self, i: Any) -> Any:
        """Index of ``u_i[0]`` (``u_i[1]`` follows)."""
        return 2 * i

    def nu(self, i: Any, slot: Any) -> Any:
        """Index of robot ``i``'s sensing slack ``ν`` in ``slot``."""
        return 2 * self.n_robots + i * self.n_nu + slot

    def xi(self, i: Any, slot: Any) -> Any:
        """Index of robot ``i``'s comm slack ``ξ`` in ``slot``."""
        return 2 * self.n_robots + self.n_robots * self.n_nu + i * self.n_xi + slot

    def velocities(self, decision: np.ndarray) -> np.ndarray:
        """Velocities ``(n, 2)`` from a decision vector."""
        return np.asarray(decision[: self.n_u]).reshape(-1, 2)
