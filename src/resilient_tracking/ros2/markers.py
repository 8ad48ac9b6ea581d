"""The team's belief for RViz as a ``visualization_msgs/MarkerArray``.

Namespaces: ``targets`` (estimated positions), ``covariance`` (2-sigma position ellipses),
``zones`` (danger zones the team knows: a sensing zone's radius, comm zones as a 0.3 m circle,
around the estimated centre)
and ``robots`` (each robot's mode as text above it). Every array starts with a DELETEALL so
markers of zones or leagues that no longer exist disappear.

Building the messages takes a few milliseconds at 10×10, so a free-running node copies what
they show out of the belief (:class:`BeliefView`, cheap) on its control path and builds them
(:func:`markers_of`) in a worker thread.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.ros2 import msgs

_ELLIPSE_POINTS = 32
_COLORS = {
    "targets": msgs.ColorRGBA(0.1, 0.4, 0.9, 1.0),
    "covariance": msgs.ColorRGBA(0.1, 0.4, 0.9, 0.8),
    "sensing": msgs.ColorRGBA(0.9, 0.5, 0.1, 0.8),
    "comm": msgs.ColorRGBA(0.6, 0.1, 0.8, 0.8),
    "robots": msgs.ColorRGBA(1.0, 1.0, 1.0, 1.0),
}


def ellipse_points(mean: np.ndarray, cov: np.ndarray, n_std: float = 2.0) -> np.ndarray:
    """Closed outline (K, 2) of the ``n_std`` ellipse of a 2x2 covariance."""
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
    radii = n_std * np.sqrt(np.clip(values, 0.0, None))
    angles = np.linspace(0.0, 2.0 * np.pi, _ELLIPSE_POINTS + 1)
    circle = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return np.asarray(mean, dtype=float) + (circle * radii) @ vectors.T


def _outline(points: np.ndarray, z: float) -> list[msgs.Point]:
    return [msgs.Point(x, y, z) for x, y in np.asarray(points, dtype=float).tolist()]


@dataclass(frozen=True)
class BeliefView:
    """What the markers show, copied out of the belief: the team estimate's positions and
    position covariances, the zones any robot knows, and each robot's position and mode."""

    means: np.ndarray
    covs: np.ndarray
    zones: tuple[ZoneEstimate, ...]
    positions: np.ndarray
    modes: tuple[str, ...]

    @classmethod
    def of(cls, belief: TeamBelief, positions: np.ndarray, modes: list[str]) -> BeliefView:
        """A copy of what :func:`markers_of` needs from ``belief`` now."""
        estimate = belief.team_estimate()
        known = {key: z for kb in belief.knowledge for key, z in kb.zones.items()}
        return cls(
            means=np.array(estimate.mean[:, :2], dtype=float),
            covs=np.array(estimate.cov[:, :2, :2], dtype=float),
            zones=tuple(zone for _, zone in sorted(known.items())),
            positions=np.array(positions, dtype=float),
            modes=tuple(modes),
        )


def belief_markers(
    belief: TeamBelief,
    positions: np.ndarray,
    modes: list[str],
    header: msgs.Header,
    altitude: float,
) -> msgs.MarkerArray:
    """RViz markers of the team's belief now (:class:`BeliefView` then :func:`markers_of`)."""
    return markers_of(BeliefView.of(belief, positions, modes), header, altitude)


def markers_of(view: BeliefView, header: msgs.Header, altitude: float) -> msgs.MarkerArray:
    """RViz markers of ``view``: each target estimate with its covariance ellipse, each known
    zone, and each robot's index and mode as text at ``altitude`` (m); the first marker
    deletes the previous set."""
    markers = [msgs.Marker(header=header, action=msgs.DELETEALL)]

    def add(ns: str, kind: int, **fields: object) -> None:
        markers.append(
            msgs.Marker(header=header, ns=ns, id=len(markers), type=kind, action=msgs.ADD, **fields)  # type: ignore[arg-type]
        )

    for mean, cov in zip(view.means.tolist(), view.covs, strict=True):
        add(
            "targets",
            msgs.SPHERE,
            pose=msgs.Pose(position=msgs.Point(mean[0], mean[1], 0.0)),
            scale=msgs.Vector3(0.1, 0.1, 0.1),
            color=_COLORS["targets"],
        )
        add(
            "covariance",
            msgs.LINE_STRIP,
            points=_outline(ellipse_points(mean, cov), 0.0),
            scale=msgs.Vector3(0.02, 0.0, 0.0),
            color=_COLORS["covariance"],
        )
    for zone in view.zones:
        radius = zone.size if zone.kind == "sensing" else 0.3
        circle = ellipse_points(zone.mean, np.eye(2) * radius**2, n_std=1.0)
        add(
            "zones",
            msgs.LINE_STRIP,
            points=_outline(circle, 0.0),
            scale=msgs.Vector3(0.03, 0.0, 0.0),
            color=_COLORS[zone.kind],
            text=zone.key,
        )
    for robot, (xy, mode) in enumerate(zip(view.positions.tolist(), view.modes, strict=True)):
        add(
            "robots",
            msgs.TEXT_VIEW_FACING,
            pose=msgs.Pose(position=msgs.Point(xy[0], xy[1], altitude + 0.2)),
            scale=msgs.Vector3(0.0, 0.0, 0.15),
            color=_COLORS["robots"],
            text=f"{robot}: {mode}",
        )
    return msgs.MarkerArray(markers=markers)
