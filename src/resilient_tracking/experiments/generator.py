"""Random scenarios of the paper's family for the generalization benchmark (docs/generalization.md).

A generated scenario looks like the shipped ones: a team of drones starts behind a group of
ground targets that move to the east across an 10 m × 8 m workspace for 30 s, and unknown
danger zones lie where the team will meet them. What varies: 3–8 robots, 3–8 targets, each
target's motion (every kind of the scenario format: ``constant_velocity``, ``waypoints``,
``circle`` and ``ncv``), and 1–3 zones of mixed kinds (sensing, comm), persistences (temporary,
permanent) and placements relative to a target's route:

- ``on``: centred on the route, where the target is at a time of the run;
- ``beside``: 0.3–0.6 m to the side of the route at that time;
- ``ahead``: 0.6–1.0 m in front of the target along its heading at that time: on the route of
  a straight lane, on the outside of the bend of a turning one.

Where a target will be is found by advancing its scripted motion (``world.targets``); an
``ncv`` target is advanced without its noise, along its mean path. A zone's placement is
written into its ``name`` (``on-0``, ``beside-1``…) so runs and tests can group by it.

**Contact.** Near a route is not enough for a team to meet a zone: a few robots that track many
targets keep to the middle of the group, and may pass an outer lane's zone at a distance where
its hazard is nil (then both teams run the same episode and the comparison says nothing). So
the team's own path decides: the generator runs the vanilla team once on the scenario without
zones (seed 1, the default planner; the same as the vanilla team's run with zones up to its
first attack) and keeps a zone's centre only where that team's robots would suffer at least
:data:`MEET_EXPOSURE` expected attacks from it (the sum over steps and robots of the hazard's
rate): of 100 draws the first that does, else the one met most, with a log line.

Hazard intensities are chosen from a peak attack rate per step at the zone's centre, drawn in
the range of the shipped scenarios: for a gaussian hazard the peak is
``κ f_act dt / (2π √det Σ)`` (paper eq. 1 at ``x = μ``), so ``κ = peak · 2π √det Σ / (f_act dt)``.

**Adversarial targets** (``adversarial=True``, ``rtrack generate --adversarial``): each scenario
is drawn as above, then some of its targets are wrapped (:data:`ADVERSARIAL_SHARE` each, at
least one per scenario) in an ``evasive`` motion (radius 0.6–1.2 m, speed 0.25–0.45 m/s, below
the robots' 1 m/s) or a ``lure`` into one of its zones (speed 0.25–0.4 m/s, first trip at 2–10 s,
lingering 3–8 s, half of them again every 10–20 s), the lanes staying their base motions. These
draws come from their own stream, ``generator_adversarial``, so an adversarial scenario is the
plain one of the same seed and index with its targets wrapped, and the plain suite is unchanged.
The ``adversarial`` benchmark's suite is stored (:data:`ADVERSARIAL_SUITE_PATH`,
:func:`stored_adversarial_suite`).

**Beyond the paper** (``beyond=True``, ``rtrack generate --beyond``): each scenario is drawn as
above, then its zones draw the world's features beyond the paper (moving, degrading, spreading,
multimodal zones: :mod:`~resilient_tracking.experiments.beyond_features`) from their own
stream, ``generator_beyond``; the plain suite is unchanged. The ``beyond`` benchmark's suite is
stored too (:data:`BEYOND_SUITE_PATH`, :func:`stored_beyond_suite`).

All randomness comes from the ``generator`` stream of :mod:`resilient_tracking.rng`, drawn in
order, so a suite is a function of its seed (and of the planner, through the contact check)
and ``suite(seed, n)`` is the first ``n`` scenarios of any longer suite of the same seed. The
benchmark's suite is stored (:data:`SUITE_PATH`, :func:`stored_suite`) so that it stays fixed.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from resilient_tracking.experiments.beyond_features import make_beyond
from resilient_tracking.rng import stream
from resilient_tracking.scenario import Scenario, TargetSpec, parse_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.world.hazards import gaussian_pdf
from resilient_tracking.world.targets import TargetTruth

log = logging.getLogger(__name__)

#: Seed of the fixed suite the ``generalization`` experiment runs, and where it is stored.
SUITE_SEED = 2024
SUITE_PATH = Path(__file__).with_name(f"suite-{SUITE_SEED}.json")
#: Where the ``beyond`` benchmark's suite (drawn from :data:`SUITE_SEED` with ``beyond``) is.
BEYOND_SUITE_PATH = Path(__file__).with_name(f"suite-beyond-{SUITE_SEED}.json")
#: Where the ``adversarial`` benchmark's suite (drawn from :data:`SUITE_SEED` with
#: ``adversarial``) is.
ADVERSARIAL_SUITE_PATH = Path(__file__).with_name(f"suite-adversarial-{SUITE_SEED}.json")
DT = 0.1
STEPS = 300
WORKSPACE = {"xmin": -5.0, "xmax": 5.0, "ymin": -4.0, "ymax": 4.0}
#: A target's (mean) path keeps this far inside the workspace.
PATH_MARGIN = 0.6
MOTIONS = ("constant_velocity", "waypoints", "circle", "ncv")
PLACEMENTS = ("on", "beside", "ahead")
#: Peak attack rate per step at a zone's centre (the shipped scenarios use 0.1–0.2).
PEAK_RANGE = (0.1, 0.2)
#: Targets' speed (m/s); the shipped scenarios use 0.18.
SPEED_RANGE = (0.13, 0.22)
#: A zone is placed where a target is at a time in this window (s), so the team meets it.
MEET_WINDOW = (5.0, 20.0)
#: Share of an adversarial scenario's targets wrapped in an evasive or lure motion.
ADVERSARIAL_SHARE = 0.5
#: Ranges of the adversarial motions' parameters (docstring).
EVASIVE_RADIUS = (0.6, 1.2)
EVASIVE_SPEED = (0.25, 0.45)
LURE_SPEED = (0.25, 0.4)
LURE_AFTER = (2.0, 10.0)
LURE_LINGER = (3.0, 8.0)
LURE_PERIOD = (10.0, 20.0)
#: Expected attacks a zone must inflict on the zone-free vanilla team's path (module docstring):
#: a team on that path meets the zone with probability ``1 − exp(−3)`` ≈ 95 %.
MEET_EXPOSURE = 3.0


def mean_path(spec: TargetSpec, steps: int = STEPS, dt: float = DT) -> np.ndarray:
    """Positions ``(steps + 1, 2)`` of a target's scripted motion (an ``ncv`` one without noise)."""
    data = spec.model_dump()
    if data["motion"]["type"] == "ncv":
        data["motion"]["accel_std"] = 0.0
    truth = TargetTruth(TargetSpec.model_validate(data))
    rng = np.random.default_rng(0)  # unused: the mean path draws nothing
    out = [truth.position.copy()]
    for _ in range(steps):
        truth.step(dt, rng)
        out.append(truth.position.copy())
    return np.array(out)


def _inside(points: np.ndarray, margin: float) -> bool:
    ws = WORKSPACE
    return bool(
        (points[:, 0] >= ws["xmin"] + margin).all()
        and (points[:, 0] <= ws["xmax"] - margin).all()
        and (points[:, 1] >= ws["ymin"] + margin).all()
        and (points[:, 1] <= ws["ymax"] - margin).all()
    )


def _motion(kind: str, start: np.ndarray, rng: np.random.Generator) -> dict[str, Any]:
    """A motion of ``kind`` for a target starting at ``start``, heading east."""
    speed = rng.uniform(*SPEED_RANGE)
    heading = rng.uniform(-0.35, 0.35)  # rad: straight or diagonal lanes
    velocity = [speed * math.cos(heading), speed * math.sin(heading)]
    if kind == "constant_velocity":
        return {"type": "constant_velocity", "velocity": velocity}
    if kind == "ncv":
        return {"type": "ncv", "velocity": velocity, "accel_std": rng.uniform(0.005, 0.01)}
    if kind == "circle":
        radius = rng.uniform(0.5, 1.2)
        angle = rng.uniform(-math.pi / 3, math.pi / 3)
        center = start + radius * np.array([math.cos(angle), math.sin(angle)])
        sign = 1.0 if rng.random() < 0.5 else -1.0
        return {
            "type": "circle",
            "center": center.tolist(),
            "angular_speed": sign * speed / radius,
        }
    # waypoints: a lane that bends 1–3 times on its way east
    length = speed * STEPS * DT * rng.uniform(0.85, 1.0)
    n_bends = int(rng.integers(1, 4))
    xs = start[0] + length * np.arange(1, n_bends + 2) / (n_bends + 1)
    ys = start[1] + math.tan(heading) * (xs - start[0])
    ys[:-1] += rng.uniform(-0.6, 0.6, n_bends)
    points = [[float(x), float(y)] for x, y in zip(xs, ys, strict=True)]
    return {"type": "waypoints", "points": points, "speed": speed}


def _targets(n: int, rng: np.random.Generator) -> list[dict[str, Any]]:
    half_width = min(2.6, rng.uniform(0.35, 0.55) * (n - 1))
    lanes = np.linspace(-half_width, half_width, n) + rng.uniform(-1.0, 1.0) * 0.3
    x0 = rng.uniform(-3.8, -3.0)
    out = []
    for y in lanes:
        start = np.array([x0 + rng.uniform(0.0, 0.6), y + rng.uniform(-0.1, 0.1)])
        kind = MOTIONS[int(rng.integers(len(MOTIONS)))]
        spec = None
        for _ in range(50):  # redraw a motion whose mean path leaves the workspace
            data = {"start": start.tolist(), "motion": _motion(kind, start, rng)}
            margin = PATH_MARGIN + (0.5 if kind == "ncv" else 0.0)  # room for the noise
            if _inside(mean_path(TargetSpec.model_validate(data)), margin):
                spec = data
                break
        if spec is None:  # a straight lane always fits
            spec = {
                "start": start.tolist(),
                "motion": {"type": "constant_velocity", "velocity": [0.15, 0.0]},
            }
        out.append(spec)
    return out


def _robots(n: int, targets: list[dict[str, Any]], rng: np.random.Generator) -> list[dict]:
    """Robots in a column behind (west of) the westernmost target, across the targets' lanes."""
    starts = np.array([t["start"] for t in targets])
    x = max(starts[:, 0].min() - rng.uniform(0.3, 0.7), WORKSPACE["xmin"] + 0.2)
    ys = np.linspace(starts[:, 1].min(), starts[:, 1].max(), n) + rng.uniform(-0.1, 0.1, n)
    ys = np.clip(ys, WORKSPACE["ymin"] + 0.2, WORKSPACE["ymax"] - 0.2)
    return [{"start": [float(x), float(y)]} for y in ys]


def exposure(zone: dict[str, Any], paths: np.ndarray, dt: float = DT) -> float:
    """Expected attacks of ``zone`` (a gaussian hazard) on robots along ``paths`` (positions,
    any leading shape): the sum of the per-step rates ``κ f_act dt N(x; μ, Σ)`` (paper eq. 1)."""
    hazard = zone["hazard"]
    density = gaussian_pdf(paths.reshape(-1, 2), np.array(zone["mu"]), np.array(zone["sigma"]))
    return float(hazard["kappa"] * hazard["f_act"] * dt * density.sum())


def _zone(
    index: int,
    paths: list[np.ndarray],
    taken: list[np.ndarray],
    robot_paths: np.ndarray,
    rng: np.random.Generator,
) -> dict[str, Any]:
    """Zone ``index``: its kind, persistence and hazard, then a centre the team meets."""
    kind = "sensing" if rng.random() < 0.5 else "comm"
    persistence = "temporary" if rng.random() < 0.5 else "permanent"
    placement = PLACEMENTS[int(rng.integers(len(PLACEMENTS)))]
    # Σ = R diag(s1², s2²) Rᵀ: 0.22–0.6 m spread, up to 1.5 : 1 elongation
    s1 = rng.uniform(0.22, 0.6)
    s2 = s1 * rng.uniform(1 / 1.5, 1.0)
    theta = rng.uniform(0, math.pi)
    rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    sigma = rot @ np.diag([s1**2, s2**2]) @ rot.T
    sigma = (sigma + sigma.T) / 2
    peak = rng.uniform(*PEAK_RANGE)
    kappa = peak * 2 * math.pi * math.sqrt(np.linalg.det(sigma)) / DT  # f_act = 1
    zone: dict[str, Any] = {
        "name": f"{placement}-{index}",
        "kind": kind,
        "mu": [0.0, 0.0],
        "sigma": [[float(v) for v in row] for row in sigma],
        "persistence": persistence,
        "hazard": {"model": "gaussian", "f_act": 1.0, "kappa": round(float(kappa), 4)},
    }
    if kind == "sensing":
        zone["radius"] = round(float(math.sqrt(s1 * s2) * rng.uniform(0.9, 1.3)), 3)
    else:
        zone["delta2"] = round(float(rng.uniform(0.1, 0.3)), 3)
    mu = _centre(zone, placement, paths, taken, robot_paths, rng)
    taken.append(mu)
    zone["mu"] = [float(mu[0]), float(mu[1])]
    return zone


def _centre(
    zone: dict[str, Any],
    placement: str,
    paths: list[np.ndarray],
    taken: list[np.ndarray],
    robot_paths: np.ndarray,
    rng: np.random.Generator,
) -> np.ndarray:
    """A centre for ``zone`` by its placement on a route, clear of the robots' starts and the
    other zones, that the zone-free team meets (:data:`MEET_EXPOSURE`); of 100 draws, the first
    that does, else the one met most."""
    best: tuple[float, np.ndarray] | None = None
    for _ in range(100):
        path = paths[int(rng.integers(len(paths)))]
        k = int(rng.integers(int(MEET_WINDOW[0] / DT), int(MEET_WINDOW[1] / DT)))
        step = path[k + 1] - path[k - 1]
        heading = step / max(float(np.linalg.norm(step)), 1e-9)
        if placement == "on":
            candidate = path[k] + rng.uniform(-0.1, 0.1, 2)
        elif placement == "beside":
            side = 1.0 if rng.random() < 0.5 else -1.0
            candidate = path[k] + side * rng.uniform(0.3, 0.6) * np.array([-heading[1], heading[0]])
        else:
            candidate = path[k] + rng.uniform(0.6, 1.0) * heading
        clear_of_robots = np.linalg.norm(robot_paths[0] - candidate, axis=1).min() > 1.5
        clear_of_zones = all(np.linalg.norm(candidate - other) > 1.0 for other in taken)
        if not (clear_of_robots and clear_of_zones and _inside(candidate[None], 0.5)):
            continue
        met = exposure({**zone, "mu": candidate.tolist()}, robot_paths)
        if best is None or met > best[0]:
            best = (met, candidate)
        if met >= MEET_EXPOSURE:
            return candidate
    if best is None:
        return paths[0][int(MEET_WINDOW[1] / DT)]  # the first route late in the run
    log.info("zone %s: met by %.2f expected attacks at most", zone["name"], best[0])
    return best[1]


def team_paths(data: dict[str, Any], name: str) -> np.ndarray:
    """Robot positions ``(steps, robots, 2)`` of the vanilla team on ``data`` without zones."""
    free = parse_scenario(
        {**data, "team": "vanilla", "zones": [], "policy": {"name": "vanilla"}}, name
    )
    robots = run_episode(free).tables["robots"]
    n = len(free.robots)
    xy = np.stack([robots["x"].to_numpy(), robots["y"].to_numpy()], axis=1)
    return xy.reshape(-1, n, 2)


def _wrap(target: dict[str, Any], zones: list[dict[str, Any]], rng: np.random.Generator) -> str:
    """Wrap ``target``'s motion in an evasive one or a lure into one of ``zones``; a few words
    on which."""
    base = target["motion"]
    if rng.random() < 0.5:
        radius = round(float(rng.uniform(*EVASIVE_RADIUS)), 3)
        speed = round(float(rng.uniform(*EVASIVE_SPEED)), 3)
        target["motion"] = {"type": "evasive", "base": base, "radius": radius, "speed": speed}
        return f"evasive r={radius:g}"
    zone = zones[int(rng.integers(len(zones)))]["name"]
    motion: dict[str, Any] = {
        "type": "lure",
        "base": base,
        "zone": zone,
        "speed": round(float(rng.uniform(*LURE_SPEED)), 3),
        "after": round(float(rng.uniform(*LURE_AFTER)), 1),
        "linger": round(float(rng.uniform(*LURE_LINGER)), 1),
    }
    if rng.random() < 0.5:
        motion["period"] = round(float(rng.uniform(*LURE_PERIOD)), 1)
    target["motion"] = motion
    return f"lure to {zone}"


def make_adversarial(data: dict[str, Any], rng: np.random.Generator) -> None:
    """Wrap some of the targets of a generated scenario's ``data`` (at least one), drawn from
    ``rng``, and say so in its description."""
    targets, zones = data["targets"], data["zones"]
    chosen = [j for j in range(len(targets)) if rng.random() < ADVERSARIAL_SHARE]
    if not chosen:
        chosen = [int(rng.integers(len(targets)))]
    words = [f"{j} {_wrap(targets[j], zones, rng)}" for j in chosen]
    data["description"] += f" Adversarial targets: {', '.join(words)}."


def generate(
    rng: np.random.Generator,
    name: str,
    adversarial: np.random.Generator | None = None,
    beyond: np.random.Generator | None = None,
) -> Scenario:
    """One scenario of the family, drawn from ``rng``; with ``adversarial``, some of its
    targets then evade or lure, and with ``beyond`` its zones draw the features beyond the
    paper, each drawn from that generator (module docstring)."""
    n_robots = int(rng.integers(3, 9))
    n_targets = int(rng.integers(3, 9))
    targets = _targets(n_targets, rng)
    robots = _robots(n_robots, targets, rng)
    data: dict[str, Any] = {
        "name": name,
        "seed": 1,
        "dt": DT,
        "steps": STEPS,
        "workspace": dict(WORKSPACE),
        "robots": robots,
        "targets": targets,
        "policy": {"name": "failure_aware"},
    }
    paths = [mean_path(TargetSpec.model_validate(t)) for t in targets]
    robot_paths = team_paths(data, name)
    taken: list[np.ndarray] = []
    zones = [_zone(i, paths, taken, robot_paths, rng) for i in range(int(rng.integers(1, 4)))]
    kinds = sorted({z["kind"] for z in zones})
    data["description"] = (
        f"Generated: {n_robots} robots, {n_targets} targets "
        f"({', '.join(sorted({t['motion']['type'] for t in targets}))}), "
        f"{len(zones)} {'/'.join(kinds)} zone(s) "
        f"({', '.join(z['name'] + ' ' + z['persistence'] for z in zones)})."
    )
    data["zones"] = zones
    if adversarial is not None:
        make_adversarial(data, adversarial)
    if beyond is not None:
        make_beyond(data, robot_paths, beyond, MEET_EXPOSURE, DT)
    return parse_scenario(data, name)


def drawn(
    seed: int = SUITE_SEED, n: int = 60, adversarial: bool = False, beyond: bool = False
) -> Iterator[Scenario]:
    """The first ``n`` scenarios drawn from ``seed``, one at a time, named ``g00``, ``g01``…;
    with ``adversarial``, with evading and luring targets, with ``beyond``, with the zone
    features beyond the paper (module docstring)."""
    rng = stream(seed, "generator")
    wrapping = stream(seed, "generator_adversarial") if adversarial else None
    features = stream(seed, "generator_beyond") if beyond else None
    for i in range(n):
        scenario = generate(rng, f"g{i:02d}", wrapping, features)
        log.info("generated %s: %s", scenario.name, scenario.description)
        yield scenario


def suite(
    seed: int = SUITE_SEED, n: int = 60, adversarial: bool = False, beyond: bool = False
) -> list[Scenario]:
    """The first ``n`` scenarios drawn from ``seed``, named ``g00``, ``g01``… (with evading and
    luring targets if ``adversarial``, with the zone features beyond the paper if ``beyond``)."""
    return list(drawn(seed, n, adversarial, beyond))


def stored_suite(n: int | None = None) -> list[Scenario]:
    """The first ``n`` (default all) scenarios of the fixed suite, as written to
    :data:`SUITE_PATH` by ``tools/generate_suite.py`` from ``suite(SUITE_SEED)``."""
    return _stored(SUITE_PATH, n)


def stored_adversarial_suite(n: int | None = None) -> list[Scenario]:
    """The first ``n`` (default all) scenarios of the ``adversarial`` benchmark's suite, as
    written to :data:`ADVERSARIAL_SUITE_PATH` by ``tools/generate_suite.py --adversarial`` from
    ``suite(SUITE_SEED, adversarial=True)``."""
    return _stored(ADVERSARIAL_SUITE_PATH, n)


def stored_beyond_suite(n: int | None = None) -> list[Scenario]:
    """The first ``n`` (default all) scenarios of the ``beyond`` benchmark's suite, as written
    to :data:`BEYOND_SUITE_PATH` by ``tools/generate_suite.py --beyond`` from
    ``suite(SUITE_SEED, beyond=True)``."""
    return _stored(BEYOND_SUITE_PATH, n)


def _stored(path: Path, n: int | None) -> list[Scenario]:
    """The first ``n`` (all if None) scenarios of the suite file ``path``."""
    data = json.loads(path.read_text(encoding="utf-8"))
    return [parse_scenario(d, d["name"]) for d in data["scenarios"][:n]]
