"""Partial degradation by zones whose ``effect`` is ``degrade`` (docs/model.md §2): truth only.

A degraded capability keeps working, worse. Each robot holds at most one degradation per zone;
several zones compose: noise factors multiply, biases add, and dropout or loss probabilities
combine as independent losses (``1 − Π(1 − p)``).

* Sensing: each measurement of a degraded robot is drawn again by the world with its noise
  standard deviation times the factor and the bias added to its range channel
  (``MeasurementModel.RANGE``; none for a sensor without range), and is lost with the dropout
  probability. The robot's filter keeps its nominal ``R``.
* Comm: each link of a degraded robot is down for the step with the loss probability (both
  ends' losses combined), drawn per link and step, so leagues form over the links that remain.

Randomness comes from streams of their own (``degraded_noise``, ``measurement_dropout``,
``link_loss``), drawn for every pair every step once a scenario has a degrading zone of that
kind, and never otherwise: a scenario without one draws exactly what it drew before.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from resilient_tracking.events import Event
from resilient_tracking.models.sensor import MeasurementModel, wrap_angle
from resilient_tracking.observation import FailureKind
from resilient_tracking.rng import stream
from resilient_tracking.scenario import Scenario
from resilient_tracking.scenario.effects import CommDegrade, SensingDegrade
from resilient_tracking.world.zones import TrueZone

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Degradation:
    """An active degradation of one capability of one robot by one zone."""

    zone_id: int
    persistence: str  # "temporary" | "permanent"
    since_step: int
    announced: bool


class Degradations:
    """Every robot's active degradations, and what they do to measurements and links."""

    def __init__(self, scenario: Scenario, seed: int):
        m = len(scenario.robots)
        kinds = {z.kind for z in scenario.zones if z.effect.type == "degrade"}
        self._effects: dict[int, SensingDegrade | CommDegrade] = {
            k: z.effect
            for k, z in enumerate(scenario.zones)
            if isinstance(z.effect, SensingDegrade | CommDegrade)
        }
        self._rng_noise = stream(seed, "degraded_noise") if "sensing" in kinds else None
        self._rng_dropout = stream(seed, "measurement_dropout") if "sensing" in kinds else None
        self._rng_loss = stream(seed, "link_loss") if "comm" in kinds else None
        #: per kind, per robot: zone id → its active degradation
        self.active: dict[FailureKind, list[dict[int, Degradation]]] = {
            "sensing": [{} for _ in range(m)],
            "comm": [{} for _ in range(m)],
        }
        #: truth events (onsets and ends) not yet taken by the recorder
        self.pending: list[Event] = []

    def degraded(self, kind: FailureKind) -> np.ndarray:
        """``(m,)`` bool: whose sensor or radio is degraded now."""
        return np.array([bool(d) for d in self.active[kind]])

    # ------------------------------------------------------------------ onset and end

    def start(self, robot: int, zone: TrueZone, step: int) -> bool:
        """``zone`` degrades ``robot``; returns whether this is new (a zone already degrading
        the robot changes nothing)."""
        kind: FailureKind = "sensing" if zone.kind == "sensing" else "comm"
        held = self.active[kind][robot]
        if zone.id in held:
            return False
        effect = self._effects[zone.id]
        persistence = zone.spec.persistence
        held[zone.id] = Degradation(zone.id, persistence, step, effect.announced)
        self.pending.append(
            Event.degraded(step, robot, kind, zone.id, persistence, effect.announced)
        )
        log.debug("step %d: robot %d %s degraded by zone %d", step, robot, kind, zone.id)
        return True

    def recover(
        self, positions: np.ndarray, zones: list[TrueZone], step: int
    ) -> list[tuple[int, FailureKind]]:
        """End each temporary degradation (held at least one step) whose robot left the zone's
        influence region; returns the announced ones that ended, as ``(robot, kind)``."""
        if not self._effects:  # no zone degrades: none to end
            return []
        announced: list[tuple[int, FailureKind]] = []
        for kind in ("sensing", "comm"):
            for robot, held in enumerate(self.active[kind]):  # type: ignore[index]
                for zone_id, d in list(held.items()):
                    if d.persistence == "permanent" or d.since_step >= step:
                        continue
                    if zones[zone_id].in_influence(positions[robot]):
                        continue
                    del held[zone_id]
                    self.pending.append(Event.degradation_ended(step, robot, kind, zone_id))
                    if d.announced:
                        announced.append((robot, kind))  # type: ignore[arg-type]
        return announced

    def take_events(self) -> list[Event]:
        """The truth events since the last call, in order."""
        out, self.pending = self.pending, []
        return out

    # ------------------------------------------------------------------ effects

    def noise_factor(self, robot: int) -> float:
        """The factor on the robot's measurement noise standard deviation now (1: nominal)."""
        return self._combined("sensing", robot)[0]

    def _combined(self, kind: FailureKind, robot: int) -> tuple[float, float, float]:
        """Noise factor, bias and loss probability of a robot's degradations of ``kind``."""
        factor, bias, kept = 1.0, 0.0, 1.0
        for zone_id in self.active[kind][robot]:
            effect = self._effects[zone_id]
            if isinstance(effect, SensingDegrade):
                factor *= effect.noise_factor
                bias += effect.bias
                kept *= 1.0 - effect.dropout
            else:
                kept *= 1.0 - effect.loss_probability
        return factor, bias, 1.0 - kept

    def measure(
        self,
        z: np.ndarray,
        sensor: MeasurementModel,
        positions: np.ndarray,
        targets: np.ndarray,
    ) -> np.ndarray:
        """``z`` (M, N, D) with each degraded robot's measurements drawn again degraded
        (noise ``factor · √R(d)``, the bias on the range channel) and dropped (NaN)."""
        if self._rng_noise is None or self._rng_dropout is None:
            return z
        eps = self._rng_noise.standard_normal(z.shape)
        u = self._rng_dropout.random(z.shape[:2])
        rows = [i for i, held in enumerate(self.active["sensing"]) if held]
        if not rows:
            return z
        z = z.copy()
        for i in rows:
            factor, bias, dropout = self._combined("sensing", i)
            clean = sensor.predict(positions[i][None, :], targets)  # (N, D)
            std = np.sqrt(
                sensor.noise_variance(sensor.noise_distance(positions[i], targets, clean))
            )
            row = clean + factor * std * eps[i]
            if sensor.RANGE is not None:
                row[:, sensor.RANGE] += bias
            for a in sensor.ANGLES:
                row[:, a] = wrap_angle(row[:, a])
            row[u[i] < dropout] = math.nan
            z[i] = row
        return z

    def drop_links(self, links: np.ndarray) -> np.ndarray:
        """``links`` without the links lost this step: link ``i–j`` is down with probability
        ``1 − (1 − q_i)(1 − q_j)``, ``q`` each end's combined loss probability."""
        if self._rng_loss is None:
            return links
        m = len(links)
        u = self._rng_loss.random((m, m))
        q = np.array([self._combined("comm", i)[2] for i in range(m)])
        if not q.any():
            return links
        p_link = 1.0 - np.outer(1.0 - q, 1.0 - q)
        lost = np.triu(u < p_link, 1)
        return links & ~(lost | lost.T)
