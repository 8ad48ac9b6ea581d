"""Zone knowledge that ages and moves (beyond the paper, docs/model.md §6.3).

A clue is a snapshot of a zone's prior mean ``μ(t)`` and covariance ``Σ`` at the attack
(docs/model.md §2.2); the team is never told how the zone moves. With zone motion on, each
robot keeps, per identified zone estimate, a small Kalman filter over the prior mean and its
velocity (nearly constant velocity), fed with every clue of that zone: its mean at the clue's
time. The mean of a clue is exact (it is ``μ(t)``); the clue's ``Σ`` is the zone's own spread
about that mean (eq. 4), not an error of it, so the filter's measurement noise is a small
``mean_std`` and the zone is believed at ``μ̂(t) + N(0, Σ + P_pos(t))`` at plan time ``t``:
the filter's prediction, whose position covariance ``P_pos`` grows with the time since the
last clue (optionally capped), widening the chance-constraint margins of eqs. 7c/7d.

Within a league the tracks are shared like knowledge: per zone, the track with the latest clue
(then the most clues) wins. The predicted estimate of a zone is republished only when it has
moved (mean, or largest standard deviation) more than ``refresh`` since it was last
published, so zone rows and route maps are rebuilt only that often.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from pydantic import Field

from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.spec import MAX_ACCEL, MAX_POSITION_STD, MAX_SPEED, Length, Strict


class ZoneMotionSettings(Strict):
    """Zone estimates that age and move: a nearly-constant-velocity Kalman filter per identified
    zone, fed with the means of successive clues."""

    enabled: bool = Field(
        False,
        description=(
            "Beyond the paper: each identified zone's clues feed a filter of its mean and"
            " velocity; the team plans against the zone predicted at plan time, its spread"
            " grown by the filter's position uncertainty. false, the default: zone estimates"
            " stay where they were learned (the paper's team)."
        ),
    )
    accel_std: float = Field(
        0.02,
        ge=0,
        le=MAX_ACCEL,
        description=(
            "Process noise: white-noise acceleration of the nearly-constant-velocity model"
            " (spectral density accel_std²)."
        ),
        json_schema_extra={"unit": "m/s²"},
    )
    speed_std: float = Field(
        0.02,
        ge=0,
        le=MAX_SPEED,
        description=(
            "Prior standard deviation of a zone's velocity (each axis) before its second clue:"
            " how fast the knowledge of a zone seen once grows uncertain."
        ),
        json_schema_extra={"unit": "m/s"},
    )
    mean_std: float = Field(
        0.05,
        gt=0,
        le=MAX_POSITION_STD,
        description=(
            "Measurement noise of a clue's mean (a clue gives the zone's prior mean as it is at"
            " the attack; its covariance is the zone's own spread, kept apart)."
        ),
        json_schema_extra={"unit": "m"},
    )
    max_std: float = Field(
        1.0,
        ge=0,
        le=MAX_POSITION_STD,
        description=(
            "Cap on the standard deviation (largest axis) the filter adds to a zone's spread;"
            " 0: no cap."
        ),
        json_schema_extra={"unit": "m"},
    )
    refresh: Length = Field(
        0.1,
        description=(
            "Distance the predicted zone (its mean, or its largest standard deviation) moves"
            " before the team replans around the new prediction; keeps zone rows and route"
            " maps from being rebuilt every step. 0: every step."
        ),
        json_schema_extra={"unit": "m"},
    )


@dataclass(frozen=True)
class ZoneTrack:
    """One zone's filter: state ``[x, y, vx, vy]`` at ``step`` (the last clue's), covariance."""

    state: np.ndarray
    cov: np.ndarray
    step: int
    clues: int

    @classmethod
    def start(cls, mean: np.ndarray, step: int, s: ZoneMotionSettings) -> ZoneTrack:
        """A track from a first clue: the clue's mean, velocity unknown (``speed_std``)."""
        state = np.concatenate([np.asarray(mean, dtype=float), np.zeros(2)])
        cov = np.diag([s.mean_std**2] * 2 + [s.speed_std**2] * 2)
        return cls(state, cov, step, 1)

    def predict(self, step: int, s: ZoneMotionSettings, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """State and covariance predicted to ``step`` of ``dt`` seconds (nearly constant
        velocity, continuous white-noise acceleration of spectral density ``accel_std²``)."""
        tau = max(step - self.step, 0) * dt
        f = np.eye(4)
        f[0, 2] = f[1, 3] = tau
        q = s.accel_std**2 * np.kron(
            np.array([[tau**3 / 3, tau**2 / 2], [tau**2 / 2, tau]]), np.eye(2)
        )
        return f @ self.state, f @ self.cov @ f.T + q

    def update(self, mean: np.ndarray, step: int, s: ZoneMotionSettings, dt: float) -> ZoneTrack:
        """The track after a clue with ``mean`` at ``step`` (a Kalman update, ``H = [I 0]``)."""
        x, p = self.predict(step, s, dt)
        innovation_cov = p[:2, :2] + s.mean_std**2 * np.eye(2)
        gain = np.linalg.solve(innovation_cov, p[:2, :]).T  # P Hᵀ S⁻¹ (S symmetric)
        x = x + gain @ (np.asarray(mean, dtype=float) - x[:2])
        p = p - gain @ p[:2, :]
        return ZoneTrack(x, 0.5 * (p + p.T), max(step, self.step), self.clues + 1)

    @property
    def velocity(self) -> np.ndarray:
        """Estimated velocity (m/s) at the last clue."""
        return self.state[2:].copy()


def _newer(a: ZoneTrack, b: ZoneTrack) -> bool:
    """Whether track ``a`` carries later knowledge than ``b`` (latest clue, then most clues,
    then the smaller covariance)."""
    return (a.step, a.clues, -float(np.trace(a.cov))) > (
        b.step,
        b.clues,
        -float(np.trace(b.cov)),
    )


class ZoneMotionTracker:
    """Each robot's zone tracks, shared within leagues; predicted knowledge at plan time."""

    def __init__(self, n_robots: int, settings: ZoneMotionSettings, dt: float):
        self.settings = settings
        #: seconds per step
        self.dt = dt
        self.tracks: list[dict[str, ZoneTrack]] = [{} for _ in range(n_robots)]
        #: per league and zone key: the track and estimate it was published from, and the
        #: published (predicted) estimate
        self._published: dict[
            tuple[tuple[int, ...], str], tuple[ZoneTrack, ZoneEstimate, ZoneEstimate]
        ] = {}

    def observe(self, robot: int, estimate: ZoneEstimate, step: int) -> None:
        """Feed a clue of an identified zone (an attack, or a hazard map's zone) to the robot's
        track of it; estimates without an identity are not tracked."""
        if estimate.zone_id is None:
            return
        held = self.tracks[robot].get(estimate.key)
        s = self.settings
        if held is None:
            self.tracks[robot][estimate.key] = ZoneTrack.start(estimate.mean, step, s)
        else:
            self.tracks[robot][estimate.key] = held.update(estimate.mean, step, s, self.dt)

    def share(self, leagues: list[list[int]]) -> None:
        """Within each league every member takes, per zone, the newest track any member holds."""
        for league in leagues:
            if len(league) < 2:
                continue
            merged: dict[str, ZoneTrack] = {}
            for i in league:
                for key, track in self.tracks[i].items():
                    held = merged.get(key)
                    if held is None or _newer(track, held):
                        merged[key] = track
            for i in league:
                self.tracks[i] = dict(merged)

    def predicted(self, league: list[int], knowledge: KnowledgeBase, step: int) -> KnowledgeBase:
        """The league's knowledge with each tracked zone predicted to ``step``: mean moved by
        the estimated velocity, covariance ``Σ + P_pos`` (capped). An estimate is the same
        object as last time until its prediction moved more than ``refresh``."""
        tracks = self.tracks[league[0]]
        names = tuple(league)
        zones: dict[str, ZoneEstimate] = {}
        for key, zone in knowledge.zones.items():
            track = tracks.get(key)
            if track is None:
                zones[key] = zone
                continue
            mean, cov = self._at(track, zone, step)
            last = self._published.get((names, key))
            if (
                last is not None
                and last[0] is track
                and last[1] is zone
                and not self._moved(last[2], mean, cov)
            ):
                zones[key] = last[2]
                continue
            published = replace(zone, mean=mean, cov=cov)
            self._published[(names, key)] = (track, zone, published)
            zones[key] = published
        return KnowledgeBase(zones)

    def _at(self, track: ZoneTrack, zone: ZoneEstimate, step: int) -> tuple[np.ndarray, np.ndarray]:
        x, p = track.predict(step, self.settings, self.dt)
        grown = p[:2, :2]
        cap = self.settings.max_std
        if cap > 0:
            largest = float(np.linalg.eigvalsh(grown)[-1])
            if largest > cap**2:
                grown = grown * (cap**2 / largest)
        return x[:2].copy(), zone.cov + grown

    def _moved(self, published: ZoneEstimate, mean: np.ndarray, cov: np.ndarray) -> bool:
        refresh = self.settings.refresh
        if float(np.linalg.norm(mean - published.mean)) > refresh:
            return True
        std_now = np.sqrt(np.linalg.eigvalsh(cov)[-1])
        std_then = np.sqrt(np.linalg.eigvalsh(published.cov)[-1])
        return bool(abs(std_now - std_then) > refresh)
