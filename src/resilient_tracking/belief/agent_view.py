"""What one robot knows, as fixed-size arrays: the observation of a learning agent.

Made from the team's belief and the tick's observation only (never the world), so it is the
same under ``rtrack run`` (:class:`~resilient_tracking.policies.learned.CallablePolicy`) and in
the learning environments (:mod:`resilient_tracking.env`). Every field is ``float32``; masks
say which rows hold something. For a team of ``M`` robots, ``N`` targets and room for ``Z``
zones, robot ``i`` sees:

========================  ============  =====================================================
field                     shape         content
========================  ============  =====================================================
``own``                   (8,)          x, y, speed bound, sensing ok, comm ok, sensing out
                                        for good, comm out for good, time (s)
``targets``               (N, 4)        its league's estimate ``[px, py, vx, vy]``
``target_cov``            (N, 4, 4)     its league's covariance of each target
``teammates``             (M, 2)        every robot's position (own included)
``teammates_mask``        (M,)          1 for the other members of its league
``zones``                 (Z, 7)        zones it knows, nearest first: x, y, σxx, σxy, σyy,
                                        size (radius or jamming strength), 1 for comm
``zones_mask``            (Z,)          1 for the rows that hold a zone
========================  ============  =====================================================
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.observation import TeamObservation

#: Room for known zones in a view, unless told otherwise (the nearest are kept).
MAX_ZONES = 8

#: The fields of a view, in order.
FIELDS = (
    "own",
    "targets",
    "target_cov",
    "teammates",
    "teammates_mask",
    "zones",
    "zones_mask",
)


@dataclass(frozen=True)
class ViewShape:
    """The sizes of a view: robots ``M``, targets ``N``, zone rows ``Z``."""

    n_robots: int
    n_targets: int
    max_zones: int = MAX_ZONES

    def shapes(self) -> dict[str, tuple[int, ...]]:
        """Each field's shape."""
        m, n, z = self.n_robots, self.n_targets, self.max_zones
        return {
            "own": (8,),
            "targets": (n, 4),
            "target_cov": (n, 4, 4),
            "teammates": (m, 2),
            "teammates_mask": (m,),
            "zones": (z, 7),
            "zones_mask": (z,),
        }


def team_views(
    belief: TeamBelief,
    obs: TeamObservation,
    u_max: np.ndarray,
    max_zones: int = MAX_ZONES,
) -> dict[str, np.ndarray]:
    """Every robot's view (module docstring) after ``belief`` took in ``obs``, each field with a
    leading axis of the ``M`` robots; ``u_max`` ``(M,)`` are their speed bounds."""
    m = obs.n_robots
    positions = obs.positions
    # the rows as Python numbers, made float32 in one call (the same rounding as NumPy's cast)
    time = float(obs.time)
    rows: list[float] = []
    for xy, bound, sensing, comm, p, q in zip(
        positions.tolist(),
        u_max.tolist(),
        obs.sensing_ok.tolist(),
        obs.comm_ok.tolist(),
        obs.sensing_persistence,
        obs.comm_persistence,
        strict=True,
    ):
        rows += (*xy, bound, sensing, comm, p == "permanent", q == "permanent", time)
    own = np.array(rows, dtype=np.float32).reshape(m, 8)
    estimates = belief.estimates
    if len(estimates) == 1:  # one league: every robot sees the same estimate
        mean, cov = estimates[0].mean, estimates[0].cov
        means = np.empty((m, *mean.shape), dtype=np.float32)
        covs = np.empty((m, *cov.shape), dtype=np.float32)
        means[:] = mean
        covs[:] = cov
    else:
        means = np.stack([e.mean for e in estimates]).astype(np.float32)[belief.league_of]
        covs = np.stack([e.cov for e in estimates]).astype(np.float32)[belief.league_of]
    if len(belief.leagues) == 1:  # one league: every other robot is a teammate
        mates = _all_others(m).copy()
    else:
        league_of = belief.league_of
        mates = (league_of[:, None] == league_of[None, :]).astype(np.float32)
        mates.flat[:: m + 1] = 0.0  # not its own teammate
    teammates = np.empty((m, m, 2), dtype=np.float32)
    teammates[:] = positions
    zones = np.zeros((m, max_zones, 7), dtype=np.float32)
    zones_mask = np.zeros((m, max_zones), dtype=np.float32)
    for robot, knowledge in enumerate(belief.knowledge):
        if knowledge.zones:
            _zone_rows(belief, robot, positions[robot], zones[robot], zones_mask[robot])
    return {
        "own": own,
        "targets": means,
        "target_cov": covs,
        "teammates": teammates,
        "teammates_mask": mates,
        "zones": zones,
        "zones_mask": zones_mask,
    }


@functools.cache
def _all_others(m: int) -> np.ndarray:
    """``(m, m)`` teammate mask of a team in one league: 1 but on the diagonal (read-only,
    shared: copied before use)."""
    mates = np.ones((m, m), dtype=np.float32)
    mates.flat[:: m + 1] = 0.0
    mates.flags.writeable = False
    return mates


def agent_view(
    belief: TeamBelief,
    obs: TeamObservation,
    robot: int,
    u_max: np.ndarray,
    max_zones: int = MAX_ZONES,
) -> dict[str, np.ndarray]:
    """Robot ``robot``'s view: its row of :func:`team_views`."""
    return {name: rows[robot] for name, rows in team_views(belief, obs, u_max, max_zones).items()}


def _zone_rows(
    belief: TeamBelief, robot: int, position: np.ndarray, zones: np.ndarray, mask: np.ndarray
) -> None:
    """Fill ``zones`` and ``mask`` with the zones ``robot`` knows, nearest (by estimated
    centre) first, as many as there are rows."""
    known = list(belief.knowledge[robot].zones.values())
    offsets = np.array([z.mean for z in known]) - position
    distances = np.hypot(offsets[:, 0], offsets[:, 1]).tolist()
    nearest = sorted(range(len(known)), key=lambda i: (distances[i], known[i].key))
    rows = []
    for i in nearest[: len(mask)]:
        z = known[i]
        (x, y), ((sxx, sxy), (_, syy)) = z.mean.tolist(), z.cov.tolist()
        rows.append((x, y, sxx, sxy, syy, z.size, z.kind == "comm"))
    if rows:  # (no rows with max_zones=0)
        zones[: len(rows)] = rows
        mask[: len(rows)] = 1.0
