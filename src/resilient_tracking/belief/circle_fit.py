"""EstimateCircleParameters (paper Alg. 3): infer a comm zone from a robot seen circling it.

A robot that loses its radio for good circles its attacker (Alg. 4). Teammates still see its
positions. They fit a circle by algebraic least squares (Kåsa: ``x² + y² = a x + b y + c``,
center ``(a/2, b/2)``, radius ``√(c + a²/4 + b²/4)``) over a sliding window and accept it only
when it is clearly a circle: enough samples, enough arc covered, small residual.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from pydantic import Field

from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.spec import MAX_RATIO, MAX_STEP_COUNT, PositiveLength, Strict


@dataclass(frozen=True)
class CircleFit:
    center: np.ndarray  # (2,)
    radius: float
    #: covariance of the center from the least-squares fit (2×2)
    center_cov: np.ndarray
    #: RMS of the geometric residual ‖p − c‖ − r (m)
    residual: float
    #: angle covered by the samples around the center (rad, up to 2π)
    arc: float
    n_samples: int


def fit_circle(points: np.ndarray) -> CircleFit | None:
    """Kåsa fit of a circle to (n, 2) points; None when degenerate (collinear, too few)."""
    points = np.asarray(points, dtype=float)
    n = len(points)
    if n < 3:
        return None
    design = np.column_stack([points, np.ones(n)])
    rhs = np.sum(points**2, axis=1)
    coef, _, rank, _ = np.linalg.lstsq(design, rhs, rcond=None)
    if rank < 3:
        return None
    a, b, c = coef
    center = np.array([a / 2, b / 2])
    r2 = c + center @ center
    if not np.isfinite(r2) or r2 <= 0:
        return None
    radius = float(np.sqrt(r2))
    geometric = np.linalg.norm(points - center, axis=1) - radius
    residual = float(np.sqrt(np.mean(geometric**2)))
    # parameter covariance s²(AᵀA)⁻¹ of the algebraic fit; the center is half of (a, b)
    dof = max(n - 3, 1)
    s2 = float(np.sum((design @ coef - rhs) ** 2)) / dof
    cov_abc = s2 * np.linalg.pinv(design.T @ design)
    center_cov = cov_abc[:2, :2] / 4.0
    return CircleFit(
        center=center,
        radius=radius,
        center_cov=0.5 * (center_cov + center_cov.T),
        residual=residual,
        arc=arc_coverage(points, center),
        n_samples=n,
    )


def arc_coverage(points: np.ndarray, center: np.ndarray) -> float:
    """Angle around ``center`` spanned by the points: 2π minus the largest angular gap."""
    angles = np.sort(np.arctan2(points[:, 1] - center[1], points[:, 0] - center[0]))
    if len(angles) < 2:
        return 0.0
    gaps = np.diff(np.concatenate([angles, [angles[0] + 2 * np.pi]]))
    return float(2 * np.pi - gaps.max())


class CircleFitSettings(Strict):
    """EstimateCircleParameters (Alg. 3): when a silent teammate is watched, when its observed
    path counts as a circle, and the comm zone inferred from one."""

    window: int = Field(
        40,
        ge=5,
        le=10_000,
        description="Last observed positions of a silent robot used in the fit.",
        json_schema_extra={"unit": "steps"},
    )
    min_samples: int = Field(
        20,
        ge=5,
        le=10_000,
        description="Fewest positions before a fit is accepted.",
        json_schema_extra={"unit": "steps"},
    )
    min_arc: float = Field(
        2.5,
        gt=0,
        le=6.2832,
        description="Smallest arc of the circle the positions must cover.",
        json_schema_extra={"unit": "rad"},
    )
    max_residual: PositiveLength = Field(
        0.08,
        description="Largest RMS radial residual of an accepted fit.",
        json_schema_extra={"unit": "m"},
    )
    min_radius: PositiveLength = Field(
        0.2, description="Smallest plausible circle radius.", json_schema_extra={"unit": "m"}
    )
    max_radius: PositiveLength = Field(
        5.0, description="Largest plausible circle radius.", json_schema_extra={"unit": "m"}
    )
    silent_steps: int = Field(
        8,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Steps without any working link before a teammate is watched.",
        json_schema_extra={"unit": "steps"},
    )
    inferred_delta2: float = Field(
        0.3,
        gt=0,
        le=MAX_RATIO,
        description=(
            "Jammer strength assumed for a comm zone inferred from a circle (its δ2 is not seen)."
        ),
        json_schema_extra={"unit": "ratio"},
    )

    def accept(self, fit: CircleFit) -> bool:
        """Whether a fit passes every gate: enough samples, enough arc, a small residual and a
        radius within bounds (Alg. 3)."""
        return (
            fit.n_samples >= self.min_samples
            and fit.arc >= self.min_arc
            and fit.residual <= self.max_residual
            and self.min_radius <= fit.radius <= self.max_radius
        )


class CircleWatcher:
    """Watches robots that went silent and infers comm zones from their circles."""

    def __init__(self, gates: CircleFitSettings):
        self.gates = gates
        self.silent_steps = gates.silent_steps
        self._tracks: dict[int, deque[np.ndarray]] = {}
        self._silent_for: dict[int, int] = {}
        self.inferred: dict[int, CircleFit] = {}

    def observe(self, robot: int, position: np.ndarray, silent: bool) -> CircleFit | None:
        """Record one observed position; returns a fit the first time one passes the gates."""
        if not silent:
            self._silent_for.pop(robot, None)
            self._tracks.pop(robot, None)
            return None
        self._silent_for[robot] = self._silent_for.get(robot, 0) + 1
        if self._silent_for[robot] < self.silent_steps or robot in self.inferred:
            return None
        track = self._tracks.setdefault(robot, deque(maxlen=self.gates.window))
        track.append(np.asarray(position, dtype=float))
        if len(track) < self.gates.min_samples:
            return None
        fit = fit_circle(np.array(track))
        if fit is None or not self.gates.accept(fit):
            return None
        self.inferred[robot] = fit
        return fit


def zone_from_circle(
    fit: CircleFit,
    robot: int,
    step: int,
    delta2: float,
    beta2: float,
    margin: float,
    persistence: str = "permanent",
) -> ZoneEstimate:
    """A comm-zone estimate at the circle's center, read with the evasion protocol in mind.

    A circling robot flies at ``β2 √(2σ²) + margin`` around its estimate of the attacker
    (``planning.evasion``), so the radius tells its teammates how uncertain that estimate
    was: ``σ = (r − margin) / (β2 √2)``. The estimate's covariance is that ``σ²`` (at least
    ``(0.1 r)²``) plus the fit's own. Its clearance is ``margin``: the comm chance margin
    ``β2 √(2σ²)`` already spans ``r − margin``, so teammates keep to the circle itself
    (plus ``δ2`` times their link length), not a second radius beyond it. Its ``δ2`` is
    assumed: nobody saw it.
    """
    sigma = max(fit.radius - margin, 0.0) / (beta2 * np.sqrt(2.0))
    spread = max(sigma, 0.1 * fit.radius) ** 2
    return ZoneEstimate(
        key=f"circle{robot}@{step}",
        kind="comm",
        mean=fit.center.copy(),
        cov=fit.center_cov + spread * np.eye(2),
        size=delta2,
        persistence=persistence,
        source="circle",
        learned_step=step,
        zone_id=None,
        clearance=margin,
    )
