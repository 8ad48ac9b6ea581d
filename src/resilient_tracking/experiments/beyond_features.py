"""The world's features beyond the paper drawn onto a generated scenario's zones
(``rtrack generate --beyond``, docs/beyond.md).

Each zone of a scenario drawn by :mod:`~resilient_tracking.experiments.generator` may, each
with its own share, become:

- **multimodal** (:data:`MULTIMODAL_SHARE`): ``kind: [sensing, comm]``, gaining the radius or
  jammer strength it lacked; its intensity is scaled by :data:`MULTIMODAL_KAPPA_FACTOR`, since
  one draw disables both capabilities (docs/model.md §2.2);
- **degrading** (:data:`DEGRADE_SHARE`, not a multimodal zone): ``effect: degrade``, announced
  or silent with even odds; a sensing zone multiplies the noise by 2–6, biases the range by up
  to 0.3 m half of the time and drops up to half the measurements; a comm zone loses each link
  with probability 0.3–0.9 per step (docs/model.md §2.1);
- **spreading** (:data:`SPREAD_SHARE`, a permanent comm zone that fails): ``spread`` with
  probability 0.02–0.08 per step, and the scenario gets a radio range of 2.5–4 m
  (``comm_range``), as the shipped ``comm-spread`` has;
- **moving** (:data:`MOTION_SHARE`): a scripted motion around the centre the generator placed,
  ``c``: an orbit (``circle``, radius 0.3–0.8 m, 0.1–0.3 rad/s), a drift (``constant_velocity``,
  0.03–0.08 m/s, at ``c`` at a time of 5–20 s) or a back-and-forth sweep through ``c``
  (``waypoints`` looping, ±0.5–1.2 m, 0.05–0.12 m/s). Like a static zone's centre (the
  generator's contact check), the motion is kept only where the zone-free vanilla team meets
  the moving zone with :data:`~resilient_tracking.experiments.generator.MEET_EXPOSURE` expected
  attacks: of :data:`MOTION_TRIES` draws the first that does, else the one met most; the zone's
  path stays in the workspace.

A scenario in which no zone drew a feature gets a degrading effect on one zone, so every
scenario has at least one. All of it is drawn from one generator (the ``generator_beyond``
stream), so the plain suite of the same seed is unchanged and a beyond scenario is the plain one
of the same seed and index with these features added.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Iterable
from typing import Any

import numpy as np

from resilient_tracking.scenario import Scenario, TargetSpec
from resilient_tracking.world.targets import TargetTruth

log = logging.getLogger(__name__)

#: Share of zones that become multimodal, degrade, spread (of the eligible ones) and move.
MULTIMODAL_SHARE = 0.2
DEGRADE_SHARE = 0.35
SPREAD_SHARE = 0.6
MOTION_SHARE = 0.5
#: Factor on a multimodal zone's κ (the shipped ``multimodal`` needed 0.8 instead of 2.0).
MULTIMODAL_KAPPA_FACTOR = 0.5
#: Ranges of the drawn parameters (module docstring).
NOISE_FACTOR = (2.0, 6.0)
BIAS = (0.0, 0.3)
DROPOUT = (0.0, 0.5)
LOSS_PROBABILITY = (0.3, 0.9)
SPREAD_PROBABILITY = (0.02, 0.08)
COMM_RANGE = (2.5, 4.0)
ORBIT_RADIUS = (0.3, 0.8)
ORBIT_RATE = (0.1, 0.3)
DRIFT_SPEED = (0.03, 0.08)
SWEEP_HALF = (0.5, 1.2)
SWEEP_SPEED = (0.05, 0.12)
MOTION_KINDS = ("circle", "constant_velocity", "waypoints")
#: Draws of a zone's motion before the one met most is kept.
MOTION_TRIES = 30


def zone_path(mu: np.ndarray, motion: dict[str, Any], steps: int, dt: float) -> np.ndarray:
    """Positions ``(steps, 2)`` of a zone starting at ``mu`` moved by ``motion`` (scripted)."""
    truth = TargetTruth(TargetSpec.model_validate({"start": mu.tolist(), "motion": motion}))
    rng = np.random.default_rng(0)  # unused: scripted motions draw nothing
    out = []
    for _ in range(steps):
        out.append(truth.position.copy())
        truth.step(dt, rng)
    return np.array(out)


def moving_exposure(
    zone: dict[str, Any], path: np.ndarray, robot_paths: np.ndarray, dt: float
) -> float:
    """Expected attacks (paper eq. 1 summed over steps and robots) of a gaussian zone whose
    centre is at ``path[t]`` at step ``t`` on robots at ``robot_paths[t]``, shape
    ``(steps, robots, 2)``."""
    sigma = np.array(zone["sigma"], dtype=float)
    inv, norm = np.linalg.inv(sigma), 2 * math.pi * math.sqrt(np.linalg.det(sigma))
    steps = min(len(path), len(robot_paths))
    diff = robot_paths[:steps] - path[:steps, None, :]
    density = np.exp(-0.5 * np.einsum("tri,ij,trj->tr", diff, inv, diff)) / norm
    hazard = zone["hazard"]
    return float(hazard["kappa"] * hazard["f_act"] * dt * density.sum())


def _motion(centre: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, dict[str, Any]]:
    """A start (the zone's new prior mean) and a motion that keep the zone around ``centre``."""
    kind = MOTION_KINDS[int(rng.integers(len(MOTION_KINDS)))]
    angle = rng.uniform(0, 2 * math.pi)
    direction = np.array([math.cos(angle), math.sin(angle)])
    if kind == "circle":
        radius = rng.uniform(*ORBIT_RADIUS)
        rate = rng.uniform(*ORBIT_RATE) * (1.0 if rng.random() < 0.5 else -1.0)
        motion = {"type": "circle", "center": centre.tolist(), "angular_speed": round(rate, 3)}
        return centre + radius * direction, motion
    if kind == "constant_velocity":
        velocity = rng.uniform(*DRIFT_SPEED) * direction
        at = rng.uniform(5.0, 20.0)
        return centre - at * velocity, {"type": "constant_velocity", "velocity": velocity.tolist()}
    half = rng.uniform(*SWEEP_HALF) * direction
    speed = round(float(rng.uniform(*SWEEP_SPEED)), 3)
    points = [(centre + half).tolist(), (centre - half).tolist()]
    return centre - half, {"type": "waypoints", "points": points, "speed": speed, "loop": True}


def _inside(points: np.ndarray, workspace: dict[str, float], margin: float) -> bool:
    return bool(
        (points[:, 0] >= workspace["xmin"] + margin).all()
        and (points[:, 0] <= workspace["xmax"] - margin).all()
        and (points[:, 1] >= workspace["ymin"] + margin).all()
        and (points[:, 1] <= workspace["ymax"] - margin).all()
    )


def _move(
    zone: dict[str, Any],
    robot_paths: np.ndarray,
    workspace: dict[str, float],
    meet: float,
    dt: float,
    rng: np.random.Generator,
) -> str | None:
    """Give ``zone`` a motion around its centre that the team meets (module docstring); the
    motion's kind, or None when no drawn path stays in the workspace."""
    centre = np.array(zone["mu"], dtype=float)
    best: tuple[float, np.ndarray, dict[str, Any]] | None = None
    for _ in range(MOTION_TRIES):
        start, motion = _motion(centre, rng)
        path = zone_path(start, motion, len(robot_paths), dt)
        if not _inside(path, workspace, 0.3):
            continue
        met = moving_exposure(zone, path, robot_paths, dt)
        if best is None or met > best[0]:
            best = (met, start, motion)
        if met >= meet:
            break
    if best is None:
        log.info("zone %s: no motion keeps it in the workspace; it stays", zone["name"])
        return None
    if best[0] < meet:
        log.info("zone %s: moving, met by %.2f expected attacks at most", zone["name"], best[0])
    zone["mu"] = [float(v) for v in best[1]]
    zone["motion"] = best[2]
    return str(best[2]["type"])


def _degrade(zone: dict[str, Any], rng: np.random.Generator) -> str:
    announced = bool(rng.random() < 0.5)
    effect: dict[str, Any] = {"type": "degrade", "announced": announced}
    if zone["kind"] == "sensing":
        effect["noise_factor"] = round(float(rng.uniform(*NOISE_FACTOR)), 2)
        if rng.random() < 0.5:
            effect["bias"] = round(float(rng.uniform(*BIAS)), 3)
        effect["dropout"] = round(float(rng.uniform(*DROPOUT)), 3)
    else:
        effect["loss_probability"] = round(float(rng.uniform(*LOSS_PROBABILITY)), 3)
    zone["effect"] = effect
    return f"degrade ({'announced' if announced else 'silent'})"


def _multimodal(zone: dict[str, Any], rng: np.random.Generator) -> str:
    sigma = np.array(zone["sigma"], dtype=float)
    if zone["kind"] == "sensing":
        zone["delta2"] = round(float(rng.uniform(0.1, 0.3)), 3)
    else:  # the generator's sensing radius: √(s1 s2) times 0.9–1.3
        size = math.sqrt(math.sqrt(np.linalg.det(sigma)))
        zone["radius"] = round(float(size * rng.uniform(0.9, 1.3)), 3)
    zone["kind"] = ["sensing", "comm"]
    zone["hazard"]["kappa"] = round(zone["hazard"]["kappa"] * MULTIMODAL_KAPPA_FACTOR, 4)
    return "multimodal"


def make_beyond(
    data: dict[str, Any],
    robot_paths: np.ndarray,
    rng: np.random.Generator,
    meet: float,
    dt: float,
) -> None:
    """Draw the features of the module docstring onto the zones of a generated scenario's
    ``data`` (in place) from ``rng``, and say which in its description."""
    words = []
    for zone in data["zones"]:
        u = rng.random(4)  # multimodal, degrade, spread, motion: one draw each, every zone
        features = []
        if u[0] < MULTIMODAL_SHARE:
            features.append(_multimodal(zone, rng))
        elif u[1] < DEGRADE_SHARE:
            features.append(_degrade(zone, rng))
        elif zone["kind"] == "comm" and zone["persistence"] == "permanent" and u[2] < SPREAD_SHARE:
            probability = round(float(rng.uniform(*SPREAD_PROBABILITY)), 3)
            zone["spread"] = {"probability": probability}
            if "comm_range" not in data:
                data["comm_range"] = round(float(rng.uniform(*COMM_RANGE)), 2)
            features.append(f"spread {probability:g}")
        if u[3] < MOTION_SHARE:
            moved = _move(zone, robot_paths, data["workspace"], meet, dt, rng)
            if moved is not None:
                features.append(f"moving ({moved})")
        if features:
            words.append(f"{zone['name']} {', '.join(features)}")
    if not words:  # every scenario has a feature: one zone degrades
        zone = data["zones"][int(rng.integers(len(data["zones"])))]
        words.append(f"{zone['name']} {_degrade(zone, rng)}")
    data["description"] += f" Beyond the paper: {'; '.join(words)}."


def feature_counts(scenarios: Iterable[Scenario]) -> Counter[str]:
    """How many zones of ``scenarios`` have each feature beyond the paper (a zone counts once
    per feature), and how many scenarios have a radio range (``comm_range``)."""
    counts: Counter[str] = Counter()
    for scenario in scenarios:
        counts["scenarios"] += 1
        counts["zones"] += len(scenario.zones)
        counts["scenarios with a radio range"] += scenario.comm_range is not None
        for zone in scenario.zones:
            if zone.motion is not None:
                counts[f"moving ({zone.motion.type})"] += 1
            if len(zone.kinds) == 2:
                counts["multimodal"] += 1
            if zone.effect.type == "degrade":
                how = "announced" if zone.effect.announced else "silent"
                counts[f"degrading {zone.kinds[0]} ({how})"] += 1
            counts["spreading"] += getattr(zone, "spread", None) is not None
    return counts
