"""What a team knows about itself: time step, velocity bounds, workspace, its sensor model."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.robot_motion import SMALL_TEAM
from resilient_tracking.models.sensor import MeasurementModel


@dataclass(frozen=True)
class TeamConfig:
    """What a team knows about itself (module docstring); the same for every policy."""

    dt: float
    u_max: np.ndarray  # (M,)
    lower: np.ndarray  # (2,) workspace corner
    upper: np.ndarray  # (2,)
    sensor: MeasurementModel
    target_model: NearlyConstantVelocity
    #: links beyond this distance are lost without any jammer (None: no range limit)
    comm_range: float | None = None
    #: the whole team's last bounds: [positions' bytes, their shape, lower, upper]
    _team_bounds: list[Any] = field(default_factory=list, init=False, repr=False, compare=False)

    @property
    def n_robots(self) -> int:
        """Number of robots ``M``."""
        return len(self.u_max)

    def velocity_bounds(
        self, robots: list[int], positions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per-axis bounds on ``u`` that respect ``u_max`` and keep ``x + u dt`` in the box.

        The whole team's bounds (``robots`` all, in order) are kept for the last positions
        asked (read-only), as a tick asks for them more than once."""
        everyone = self._everyone
        whole = len(positions) == len(everyone) and (
            robots == everyone if type(robots) is list else list(robots) == everyone
        )
        if whole and isinstance(positions, np.ndarray) and positions.dtype == np.float64:
            key = positions.tobytes()
            memo = self._team_bounds
            if memo and memo[0] == key and memo[1] == positions.shape:
                return memo[2], memo[3]
            bounds = None
            if 0 < len(positions) <= SMALL_TEAM and positions.ndim == 2 and positions.shape[1] == 2:
                bounds = self._bounds_floats(positions.tolist())
            lower, upper = bounds or self._bounds(*self._team_umax, positions)
            lower.flags.writeable = upper.flags.writeable = False
            memo[:] = [key, positions.shape, lower, upper]
            return lower, upper
        if whole:
            return self._bounds(*self._team_umax, positions)
        umax = self.u_max[robots][:, None]
        return self._bounds(umax, -umax, positions[robots])

    def _bounds(
        self, umax: np.ndarray, negative: np.ndarray, x: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        # room to each corner, (corner − x) / dt, for both corners in one pass (elementwise:
        # the same numbers as one corner at a time)
        corners, dt, zero = self._corners
        to_lower, to_upper = np.divide(np.subtract(corners, x), dt)
        lower = np.minimum(np.maximum(negative, to_lower), zero)
        upper = np.maximum(np.minimum(umax, to_upper), zero)
        return lower, upper

    def clip(self, controls: np.ndarray, positions: np.ndarray) -> np.ndarray:
        """``controls`` clipped to :meth:`velocity_bounds` at ``positions`` (robots in order,
        one row each), ``np.minimum(np.maximum(u, lower), upper)``: a small team's finite
        controls in Python floats (:meth:`clip_floats`), anything else with NumPy (which
        broadcasts, and keeps NaN)."""
        if controls.shape == positions.shape:
            flat = controls.ravel().tolist()
            if math.isfinite(sum(flat)):  # (a finite sum has finite terms)
                clipped = self.clip_floats(positions.tolist(), flat)
                if clipped is not None:
                    return np.array(clipped).reshape(controls.shape)
        lower, upper = self.velocity_bounds(list(range(len(controls))), positions)
        return np.minimum(np.maximum(controls, lower), upper)

    def clip_floats(self, rows: list[list[float]], controls: list[float]) -> list[float] | None:
        """The whole team's finite ``controls`` (flat: ``[ux0, uy0, ux1, …]``) clipped to
        :meth:`velocity_bounds` at the positions ``rows``, ``np.minimum(np.maximum(u, lower),
        upper)``, in Python floats for a small team: the same comparisons per component, a tie
        giving the bound as NumPy's do (±0). ``None`` when :meth:`velocity_bounds` would take
        NumPy's path (then clip with its arrays)."""
        if len(rows) > SMALL_TEAM:
            return None
        bounds = self._flat_bounds(rows)
        if bounds is None:
            return None
        clipped = []
        for u, low, high in zip(controls, *bounds, strict=True):
            u = u if u > low else low  # np.maximum(u, lower)
            clipped.append(u if u < high else high)  # np.minimum(…, upper)
        return clipped

    def _bounds_floats(self, rows: list[list[float]]) -> tuple[np.ndarray, np.ndarray] | None:
        """:meth:`_bounds` for the whole team, a small one, in Python floats (``None``: NumPy's
        path, as :meth:`_flat_bounds`)."""
        bounds = self._flat_bounds(rows)
        if bounds is None:
            return None
        both = np.array(bounds[0] + bounds[1]).reshape(2, len(rows), 2)  # (one array: fewer calls)
        return both[0], both[1]

    def _flat_bounds(self, rows: list[list[float]]) -> tuple[list[float], list[float]] | None:
        """The whole team's lower and upper bounds per component, flat, in Python floats: the
        same IEEE operations per component as :meth:`_bounds`, ties of ``max``/``min`` giving
        the second operand as NumPy's do (±0). ``None`` (NumPy's path, which propagates it)
        when a NaN turns up."""
        if self._floats is None:
            return None
        (lx, ly, ux, uy), dt, umaxes = self._floats
        lower, upper = [], []
        for (x, y), umax in zip(rows, umaxes, strict=True):
            negative = -umax
            for to_l, to_u in (((lx - x) / dt, (ux - x) / dt), ((ly - y) / dt, (uy - y) / dt)):
                if to_l != to_l or to_u != to_u:
                    return None
                low = negative if negative > to_l else to_l  # np.maximum(negative, to_lower)
                lower.append(low if low < 0.0 else 0.0)  # np.minimum(…, 0)
                high = umax if umax < to_u else to_u  # np.minimum(umax, to_upper)
                upper.append(high if high > 0.0 else 0.0)  # np.maximum(…, 0)
        return lower, upper

    @functools.cached_property
    def _floats(self) -> tuple[list[float], float, list[float]] | None:
        """The corners ``[lx, ly, ux, uy]``, ``dt`` and ``u_max`` as Python floats (``None``
        if ``u_max`` holds NaN: NumPy's path)."""
        corners, dt, _ = self._corners
        umax = self._team_umax[0]
        if corners.size != 4 or np.isnan(umax).any():
            return None
        return corners.ravel().tolist(), float(dt), umax.ravel().tolist()

    @functools.cached_property
    def _everyone(self) -> list[int]:
        """The whole team's indices, in order."""
        return list(range(len(self.u_max)))

    @functools.cached_property
    def _corners(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The workspace corners as ``(2, 1, 2)`` (lower, upper), ``dt`` and 0 as 0-d arrays
        (faster in NumPy operations than Python floats, the same numbers)."""
        corners = np.array([self.lower, self.upper], dtype=float).reshape(2, 1, 2)
        return corners, np.array(float(self.dt)), np.array(0.0)

    @functools.cached_property
    def _team_umax(self) -> tuple[np.ndarray, np.ndarray]:
        """``u_max`` and ``−u_max`` as columns ``(M, 1)``."""
        umax = self.u_max[:, None]
        return umax, -umax
