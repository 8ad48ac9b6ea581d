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


def agent_view(
    belief: TeamBelief,
    obs: TeamObservation,
    robot: int,
    u_max: float,
    max_zones: int = MAX_ZONES,
) -> dict[str, np.ndarray]:
    """Robot ``robot``'s view (module docstring) after ``belief`` took in ``obs``;
    ``u_max`` is the robot's speed bound."""
    league = int(belief.league_of[robot])
    estimate = belief.estimates[league]
    position = obs.positions[robot]
    own = np.array(
        [
            position[0],
            position[1],
            u_max,
            obs.sensing_ok[robot],
            obs.comm_ok[robot],
            obs.sensing_persistence[robot] == "permanent",
            obs.comm_persistence[robot] == "permanent",
            obs.time,
        ],
        dtype=np.float32,
    )
    mates = np.zeros(obs.n_robots, dtype=np.float32)
    mates[belief.leagues[league]] = 1.0
    mates[robot] = 0.0
    return {
        "own": own,
        "targets": estimate.mean.astype(np.float32),
        "target_cov": estimate.cov.astype(np.float32),
        "teammates": obs.positions.astype(np.float32),
        "teammates_mask": mates,
        **_zone_rows(belief, robot, position, max_zones),
    }


def _zone_rows(
    belief: TeamBelief, robot: int, position: np.ndarray, max_zones: int
) -> dict[str, np.ndarray]:
    """The zones ``robot`` knows, nearest (by estimated centre) first, padded to ``max_zones``."""
    zones = np.zeros((max_zones, 7), dtype=np.float32)
    mask = np.zeros(max_zones, dtype=np.float32)
    known = sorted(
        belief.knowledge[robot].zones.values(),
        key=lambda z: (float(np.hypot(*(z.mean - position))), z.key),
    )
    for row, z in enumerate(known[:max_zones]):
        cov = z.cov
        zones[row] = (
            z.mean[0],
            z.mean[1],
            cov[0, 0],
            cov[0, 1],
            cov[1, 1],
            z.size,
            z.kind == "comm",
        )
        mask[row] = 1.0
    return {"zones": zones, "zones_mask": mask}
