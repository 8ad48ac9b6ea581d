"""CircularEvasionMode (paper Alg. 4): circle the estimated attacker at a safe clearance."""

from __future__ import annotations

import numpy as np


def evasion_radius(sigma: np.ndarray, beta2: float, margin: float) -> float:
    """Clearance where the comm chance constraint holds alone: ``β2 √(2 λmax(Σ))`` + margin."""
    return float(beta2 * np.sqrt(2.0 * np.linalg.eigvalsh(sigma).max()) + margin)


def circle_velocity(
    position: np.ndarray,
    center: np.ndarray,
    radius: float,
    speed: float,
    u_max: float,
    gain: float = 2.0,
    direction: float = 1.0,
) -> np.ndarray:
    """Counter-clockwise (``direction`` 1; −1 clockwise) along the circle at ``speed``, pulled
    onto it radially.

    The command is scaled (not clipped per axis) to respect ``|u| ≤ u_max`` per component, so
    its direction, and hence the circle, is kept.
    """
    offset = np.asarray(position, dtype=float) - np.asarray(center, dtype=float)
    dist = float(np.linalg.norm(offset))
    radial = offset / dist if dist > 1e-9 else np.array([1.0, 0.0])
    tangent = direction * np.array([-radial[1], radial[0]])
    v = speed * tangent + gain * (radius - dist) * radial
    peak = float(np.abs(v).max())
    return v * min(1.0, u_max / peak) if peak > 0 else v
