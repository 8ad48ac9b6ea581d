"""Silent sensor degradation found from each robot's own measurements (docs/model.md §6.4).

A zone may degrade a sensor without telling anyone (``effect: degrade``, ``announced: false``):
the robot keeps measuring, with more noise. Its filter, still using the nominal ``R``, grows
overconfident. This watch notices it from belief alone: every tick a robot senses, each of its
measurements is compared with its league's *predicted* estimate (the prior of the update).

* **NIS.** ``q = ν̃ᵀ S⁻¹ ν̃`` with ``S = H P⁻_pp Hᵀ + R(d̂)``, χ²(D) while the sensor is as
  nominal (D the sensor's channels).
* **Detection: CUSUM** (Page 1954) on the log-likelihood ratio of a noise scaled by
  ``λ₁ = design_factor²`` (``S`` taken as ``λ₁ S`` under the alternative) against the nominal
  one, ``ℓ(q) = −(D/2) ln λ₁ + ½ (1 − 1/λ₁) min(q, nis_cap)``, summed over the robot's
  measurements of the tick: ``g ← max(0, g + Σ ℓ)``, a detection when ``g > threshold``. The cap
  bounds what one outlier (a linearisation far off next to a target) can add. A detection
  restarts the CUSUM of the league's other members: until it, the found robot's measurements
  pulled the league's estimate, and their evidence was against that. The CUSUM starts
  ``warmup`` steps after the first tick: the first updates from the wide initial prior, next to
  a target, leave the paper's EKF overconfident for a few seconds, which reads as a degraded
  sensor (docs/model.md §6.4).
* **Curvature.** ``S`` also carries each channel's second-order term ``½ tr(H″_c P H″_c P)``,
  what the prior's spread does to a measurement taken next to the target.
* **Adaptation.** ``E[ν̃ᵀ R⁻¹ ν̃] = tr(R⁻¹ H P⁻_pp Hᵀ) + λ D`` for a noise variance ``λ R``, so
  ``λ̂`` is the ratio of the sums of ``ν̃ᵀ R⁻¹ ν̃ − tr(R⁻¹ H P Hᵀ)`` and ``D`` over the robot's
  measurements, exponentially forgotten over ``memory`` steps, started at detection from the
  measurements since the CUSUM last stood at zero (its change-point estimate), and kept within
  ``[1, max_factor²]``. A detected robot's measurements are then used with ``λ̂ R``
  (:meth:`DegradationWatch.noise_scale`); covariance intersection fuses the estimates those
  updates make, so it needs nothing more.
* **A careful update while degraded.** Noise several times the nominal one makes the first
  linearisation of a range-bearing update, at the predicted position, a poor one: a league with
  a robot found degraded updates with the iterated EKF (``update_iterations`` linearisations, each
  at the last one's result) and the second-order term in the noise (``second_order``), as the
  IMM's modes do. Leagues with no degraded robot keep the estimator's own update.
* **What the team does with it.** The robot counts as the fraction ``1 − 1/λ̂`` of an attacked
  robot in the adaptive weights (the share of its information lost; :meth:`attacked_fraction`),
  and, if the team keeps zone knowledge, it learns a sensing zone (source ``degradation``) at
  its position at detection, spread ``zone_std``, radius ``zone_radius``, which its league
  shares like any clue.

Truth is never read: the watch sees the league's estimate, the robot's position and its
measurements, as the filter does.
"""

from __future__ import annotations

import logging

import numpy as np
from pydantic import Field

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.belief.silent_robots import LearningBelief
from resilient_tracking.events import Event
from resilient_tracking.models.sensor import MeasurementModel, wrap_angle
from resilient_tracking.spec import (
    MAX_POSITION_STD,
    MAX_RATIO,
    MAX_STEP_COUNT,
    MAX_UPDATE_ITERATIONS,
    PositiveLength,
    Strict,
)

log = logging.getLogger(__name__)


class DegradationWatchSettings(Strict):
    """Finding a robot's silently degraded sensor from its own measurements and adapting to it
    (docs/model.md §6.4)."""

    enabled: bool = Field(
        False,
        description=(
            "Beyond the paper: check each robot's measurements against its league's predicted"
            " estimate (NIS, CUSUM); a robot found degraded has its noise re-estimated and used"
            " by the filter, counts as partly attacked in the adaptive weights (1 − 1/λ̂ of a"
            " robot) and learns a sensing zone where it was found, shared with its league."
            " false, the default: the paper's team."
        ),
    )
    design_factor: float = Field(
        2.0,
        gt=1,
        le=MAX_RATIO,
        description=(
            "Noise standard-deviation factor the CUSUM is tuned to: the alternative hypothesis"
            " of its log-likelihood ratio (the noise variance times its square)."
        ),
        json_schema_extra={"unit": "ratio"},
    )
    threshold: float = Field(
        20.0,
        gt=0,
        le=MAX_RATIO,
        description=(
            "CUSUM threshold, a log-likelihood ratio: larger means fewer false alarms and later"
            " detections."
        ),
    )
    warmup: int = Field(
        30,
        ge=0,
        le=MAX_STEP_COUNT,
        description=(
            "Steps from the first tick before the CUSUM starts: the filter first settles from"
            " its wide initial prior."
        ),
        json_schema_extra={"unit": "steps"},
    )
    nis_cap: float = Field(
        20.0,
        gt=0,
        le=MAX_RATIO,
        description=(
            "Cap on one measurement's normalised innovation squared in the CUSUM, so one outlier"
            " adds a bounded amount."
        ),
    )
    memory: float = Field(
        30.0,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Steps over which a degraded sensor's noise estimate forgets (exponentially).",
        json_schema_extra={"unit": "steps"},
    )
    max_factor: float = Field(
        20.0,
        ge=1,
        le=MAX_RATIO,
        description="Largest noise standard-deviation factor estimated.",
        json_schema_extra={"unit": "ratio"},
    )
    zone_radius: PositiveLength = Field(
        0.5,
        description="Radius of the sensing zone learned where a degradation is found.",
        json_schema_extra={"unit": "m"},
    )
    zone_std: float = Field(
        0.5,
        gt=0,
        le=MAX_POSITION_STD,
        description="Spread of the centre of the zone learned where a degradation is found.",
        json_schema_extra={"unit": "m"},
    )
    update_iterations: int = Field(
        5,
        ge=1,
        le=MAX_UPDATE_ITERATIONS,
        description=(
            "Linearisations per measurement update of a league with a robot found degraded (the"
            " iterated EKF: each at the last one's result); 1: the estimator's own update."
        ),
        json_schema_extra={"unit": "count"},
    )
    second_order: bool = Field(
        True,
        description=(
            "Whether that update's noise carries each channel's second-order term, so a large"
            " noise next to a target does not make the update overconfident."
        ),
    )


class DegradationWatch:
    """Per robot: the CUSUM, the noise estimate and whether a degradation was found."""

    def __init__(
        self,
        n_robots: int,
        settings: DegradationWatchSettings,
        sensor: MeasurementModel,
        learn_zone: bool = True,
    ):
        self.settings = settings
        #: the team's sensor (its measurement, Jacobian and nominal noise)
        self.sensor = sensor
        #: whether a detection teaches the robot a sensing zone (teams that keep zone knowledge)
        self.learn_zone = learn_zone
        lam1 = settings.design_factor**2
        self._llr_offset = -0.5 * sensor.DIM * np.log(lam1)
        self._llr_slope = 0.5 * (1.0 - 1.0 / lam1)
        self._forget = 1.0 - 1.0 / settings.memory
        self._max_scale = settings.max_factor**2
        #: CUSUM statistic per robot
        self.cusum = np.zeros(n_robots)
        #: step at which each robot's degradation was found, −1 while none was
        self.detected_step = np.full(n_robots, -1, dtype=int)
        #: noise variance factor λ̂ per robot (1 until a degradation is found)
        self.scale = np.ones(n_robots)
        # sums of ν̃ᵀR⁻¹ν̃ − tr(R⁻¹HPHᵀ) and of D: since the CUSUM last stood at zero, and
        # exponentially forgotten (after detection)
        self._since = np.zeros((n_robots, 2))
        self._sums = np.zeros((n_robots, 2))
        #: the first tick seen
        self._first_step: int | None = None

    # ------------------------------------------------------------------ queries

    @property
    def detected(self) -> np.ndarray:
        """``(M,)`` whether each robot's sensor was found degraded."""
        return self.detected_step >= 0

    def factor(self) -> np.ndarray:
        """``(M,)`` estimated noise standard-deviation factor ``√λ̂`` (1 where none found)."""
        return np.sqrt(self.scale)

    def noise_scale(self, robots: list[int]) -> np.ndarray | None:
        """The noise variance factors of ``robots`` for the update, ``None`` when all are 1."""
        scale = self.scale[robots]
        return scale if np.any(scale != 1.0) else None

    def attacked_fraction(self) -> np.ndarray:
        """``(M,)`` how much of an attacked robot each one counts as in the adaptive weights
        (eq. 10's ``m``): ``1 − 1/λ̂``, the share of its information a degraded sensor lost."""
        return 1.0 - 1.0 / self.scale

    # ------------------------------------------------------------------ tick

    def observe(
        self,
        belief: LearningBelief,
        step: int,
        robots: list[int],
        prior: TargetEstimate,
        positions: np.ndarray,
        measurements: np.ndarray,
    ) -> list[Event]:
        """Take in the measurements of ``robots`` (one league's sensing members, at
        ``positions`` ``(K, 2)``, ``measurements`` ``(K, N, D)``, NaN where none) against the
        league's prior; return a ``degradation_detected`` event per robot found degraded now."""
        s = self.settings
        if self._first_step is None:
            self._first_step = step
        if step < self._first_step + s.warmup:
            return []
        q, excess, dof = self._consistency(prior, positions, measurements)
        events: list[Event] = []
        llr = self._llr_offset + self._llr_slope * np.minimum(q, s.nis_cap)
        llr = np.where(np.isfinite(q), llr, 0.0).sum(axis=1)
        for row, robot in enumerate(robots):
            if dof[row] == 0:
                continue
            sample = np.array([excess[row], dof[row]])
            if self.detected_step[robot] >= 0:
                self._sums[robot] = self._forget * self._sums[robot] + sample
                self.scale[robot] = self._scale_of(self._sums[robot])
                continue
            g = self.cusum[robot] + llr[row]
            if g <= 0.0:
                self.cusum[robot] = 0.0
                self._since[robot] = 0.0
                continue
            self.cusum[robot] = g
            self._since[robot] += sample
            if g > s.threshold:
                events.append(self._detect(belief, step, robot, positions[row]))
        if events:  # the others' evidence was against a prior the found robot spoilt
            others = [i for i in robots if self.detected_step[i] < 0]
            self.cusum[others] = 0.0
            self._since[others] = 0.0
        return events

    def adopt(
        self, belief: LearningBelief, step: int, robot: int, position: np.ndarray, scale: float
    ) -> list[Event]:
        """Take ``scale`` as the robot's noise variance factor from now on, a detection at
        ``step`` if the robot was not found yet (its event, and its zone clue). For a
        reference that knows the true noise instead of estimating it
        (``tools/known_noise_reference.py``); a team never calls it."""
        events = []
        if self.detected_step[robot] < 0:
            self._since[robot] = np.array([scale, 1.0])
            events.append(self._detect(belief, step, robot, position))
        self.scale[robot] = scale
        return events

    # ------------------------------------------------------------------ pieces

    def _scale_of(self, sums: np.ndarray) -> float:
        if sums[1] <= 0.0:
            return 1.0
        return float(np.clip(sums[0] / sums[1], 1.0, self._max_scale))

    def _detect(self, belief: LearningBelief, step: int, robot: int, position: np.ndarray) -> Event:
        s = self.settings
        self.detected_step[robot] = step
        self._sums[robot] = self._since[robot]
        self.scale[robot] = self._scale_of(self._sums[robot])
        factor = float(np.sqrt(self.scale[robot]))
        log.info(
            "step %d: robot %d's sensor looks degraded (noise factor %.2f, CUSUM %.1f)",
            step,
            robot,
            factor,
            self.cusum[robot],
        )
        if self.learn_zone:
            belief.learn(
                robot,
                ZoneEstimate(
                    key=f"degradation{robot}@{step}",
                    kind="sensing",
                    mean=np.array(position, dtype=float),
                    cov=s.zone_std**2 * np.eye(2),
                    size=s.zone_radius,
                    persistence="unknown",
                    source="degradation",
                    learned_step=step,
                ),
            )
        return Event.degradation_detected(
            step, robot, factor, float(self.cusum[robot]), float(position[0]), float(position[1])
        )

    def _consistency(
        self, prior: TargetEstimate, positions: np.ndarray, measurements: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per robot and target: the NIS ``q`` (NaN where not measured); per robot: the sum of
        ``ν̃ᵀR⁻¹ν̃ − tr(R⁻¹HPHᵀ)`` and the channels measured, all at the nominal ``R``."""
        sensor = self.sensor
        robots = np.asarray(positions, dtype=float).reshape(-1, 2)
        z = np.asarray(measurements, dtype=float)
        h, hjac, var = sensor.linearise(robots[:, None, :], prior.mean[None, :, :2])
        valid = np.isfinite(z).all(axis=-1)  # (K, N)
        innov = np.where(valid[..., None], z - h, 0.0)
        for channel in sensor.ANGLES:
            innov[..., channel] = wrap_angle(innov[..., channel])
        p_pp = prior.cov[None, :, :2, :2]
        hph = hjac @ p_pp @ np.swapaxes(hjac, -1, -2)  # (K, N, D, D)
        # the prior's spread seen through the measurement's curvature, ½ tr(H″_c P H″_c P)
        # (second-order EKF): next to a target a bearing varies far more than H P Hᵀ says
        hp = sensor.hessian(robots[:, None, :], prior.mean[None, :, :2]) @ p_pp[:, :, None]
        spread = np.diagonal(hph, axis1=-2, axis2=-1) + 0.5 * np.einsum("kncab,kncba->knc", hp, hp)
        s_mat = hph + (var + spread - np.diagonal(hph, axis1=-2, axis2=-1))[..., None] * np.eye(
            sensor.DIM
        )
        q = np.einsum("kna,kna->kn", innov, np.linalg.solve(s_mat, innov[..., None])[..., 0])
        q = np.where(valid, q, np.nan)
        weighted = (innov**2 - spread) / var
        excess = np.where(valid, weighted.sum(axis=-1), 0.0).sum(axis=1)
        dof = sensor.DIM * valid.sum(axis=1)
        return q, excess, dof
