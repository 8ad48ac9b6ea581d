"""The team's belief for RViz as a ``visualization_msgs/MarkerArray``.

Namespaces: ``targets`` (estimated positions), ``covariance`` (2-sigma position ellipses),
``zones`` (danger zones the team knows: a sensing zone's radius, comm zones as a 0.3 m circle,
around the estimated centre)
and ``robots`` (each robot's mode as text above it). Every array starts with a DELETEALL so
markers of zones or leagues that no longer exist disappear.
"""

from __future__ import annotations

import numpy as np

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
    return [msgs.Point(float(x), float(y), z) for x, y in points]


def belief_markers(
    belief: TeamBelief,
    positions: np.ndarray,
    modes: list[str],
    header: msgs.Header,
    altitude: float,
) -> msgs.MarkerArray:
    """RViz markers of the team's belief: each target estimate with its covariance ellipse, each
    known zone, and each robot's index and mode as text at ``altitude`` (m); the first marker
    deletes the previous set."""
    markers = [msgs.Marker(header=header, action=msgs.DELETEALL)]

    def add(ns: str, kind: int, **fields: object) -> None:
        markers.append(
            msgs.Marker(header=header, ns=ns, id=len(markers), type=kind, action=msgs.ADD, **fields)  # type: ignore[arg-type]
        )

    estimate = belief.team_estimate()
    for mean, cov in zip(estimate.mean, estimate.cov, strict=True):
        add(
            "targets",
            msgs.SPHERE,
            pose=msgs.Pose(position=msgs.Point(float(mean[0]), float(mean[1]), 0.0)),
            scale=msgs.Vector3(0.1, 0.1, 0.1),
            color=_COLORS["targets"],
        )
        add(
            "covariance",
            msgs.LINE_STRIP,
            points=_outline(ellipse_points(mean[:2], cov[:2, :2]), 0.0),
            scale=msgs.Vector3(0.02, 0.0, 0.0),
            color=_COLORS["covariance"],
        )
    known = {key: z for kb in belief.knowledge for key, z in kb.zones.items()}
    for _, zone in sorted(known.items()):
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
    for robot, (xy, mode) in enumerate(zip(positions, modes, strict=True)):
        add(
            "robots",
            msgs.TEXT_VIEW_FACING,
            pose=msgs.Pose(position=msgs.Point(float(xy[0]), float(xy[1]), altitude + 0.2)),
            scale=msgs.Vector3(0.0, 0.0, 0.15),
            color=_COLORS["robots"],
            text=f"{robot}: {mode}",
        )
    return msgs.MarkerArray(markers=markers)
