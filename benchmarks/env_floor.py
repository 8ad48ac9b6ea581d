"""What bounds the learning environment's throughput at 3×3 (``sensing-temp``, random
velocities, ``record=False``): side by side in one run, CPU µs per step of

- the environment (``TeamEnv``), as ``benchmarks.env_steps`` measures it;
- the simulator alone: the same episodes' world and belief stepped by ``EpisodeStepper`` with
  the environment's velocities, clipped as it clips them, and nothing else (no views, reward or
  info). An environment that equals ``rtrack run`` bit for bit runs these same operations, so
  it can be no faster than this;
- the belief's filter for one such step (prediction and update of 3 targets by 3 robots), as
  the package does it (NumPy, BLAS and LAPACK), and the same maths written out in Python floats
  (:func:`filter_in_floats`, a reference that is not the package's: it rounds otherwise, so
  its numbers differ in the last bits; the largest difference over a few steps is printed);
- a call of a CasADi function from Python with the filter's inputs and a trivial body: what
  the cheapest compiled path among the project's dependencies costs before it computes
  anything.

It also counts the entries of NumPy's products of 4×4 matrices (the filter's size) that no
order of plain float sums gives (:func:`products_beyond_float_sums`): where BLAS's kernels fuse
multiplies and adds, which Python 3.11's floats cannot, so float code cannot reproduce them.

    python -m benchmarks.env_floor            # about a minute
    python -m benchmarks.env_floor --quick    # a smoke run

Each measurement is the best of ``--rounds`` rounds, taken in turn; the 5,000 steps per second
asked of the environment are 200 µs per step.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from benchmarks.common import machine, save, table
from benchmarks.env_steps import cpu_us_per_step, make_env, random_actions

SCENARIO = "sensing-temp"
#: the environment's target: 5,000 steps per second
TARGET_US = 200.0
#: untimed steps before the timed ones (as ``benchmarks.env_steps.one_process`` takes)
WARM_UP = 20


def filter_in_floats(
    mean: np.ndarray,
    cov: np.ndarray,
    robots: np.ndarray,
    measurements: np.ndarray,
    dt: float,
    process_noise: np.ndarray,
    sensor: Any,
) -> tuple[np.ndarray, np.ndarray]:
    """The EKF's prediction and update of :mod:`resilient_tracking.belief.ekf` (range–bearing
    sensor, every robot measuring every target) in Python floats, written out entry by entry:
    ``A P Aᵀ + Q`` with ``A = [[I, dt I], [0, I]]``, the information ``J`` and ``b`` summed over
    the robots, ``F = P Eᵀ (I + J P_pp)⁻¹`` by the 2×2 inverse, and the Joseph form's upper
    triangle, mirrored. The package's maths, rounded otherwise."""
    from resilient_tracking.models.sensor import MAX_EXPONENT, MIN_RANGE

    (q00, q01, q02, q03), (_, q11, q12, q13), (_, _, q22, q23), (*_, q33) = process_noise.tolist()
    robot_rows, z_rows = robots.tolist(), measurements.tolist()
    r_shape, b_shape = sensor.range_shape, sensor.bearing_shape
    r_peak, b_peak = sensor.range_peak, sensor.bearing_peak
    min_d2, pi, two_pi = MIN_RANGE * MIN_RANGE, math.pi, 2.0 * math.pi
    means, covs = [], []
    for j, ((x, y, vx, vy), p) in enumerate(zip(mean.tolist(), cov.tolist(), strict=True)):
        (a00, a01, a02, a03), (_, a11, a12, a13), (_, _, a22, a23), (*_, a33) = p
        # prediction
        x, y = x + dt * vx, y + dt * vy
        p00 = a00 + dt * (a02 + a02) + dt * dt * a22 + q00
        p01 = a01 + dt * (a03 + a12) + dt * dt * a23 + q01
        p11 = a11 + dt * (a13 + a13) + dt * dt * a33 + q11
        p02, p03 = a02 + dt * a22 + q02, a03 + dt * a23 + q03
        p12, p13 = a12 + dt * a23 + q12, a13 + dt * a33 + q13
        p22, p23, p33 = a22 + q22, a23 + q23, a33 + q33
        # J = Σ Hᵀ R⁻¹ H and b = Σ Hᵀ R⁻¹ z̃ over the robots, at the predicted position
        j00 = j01 = j11 = b0 = b1 = 0.0
        for (rx, ry), (zr, zb) in zip(robot_rows, [row[j] for row in z_rows], strict=True):
            dx, dy = x - rx, y - ry
            d2 = dx * dx + dy * dy
            d = math.sqrt(d2)
            ir = r_peak / math.exp(min(r_shape * d, MAX_EXPONENT))
            ib = b_peak / math.exp(min(b_shape * d, MAX_EXPONENT))
            nr, nb = zr - d, (zb - math.atan2(dy, dx) + pi) % two_pi - pi
            d2 = max(d2, min_d2)
            dc = math.sqrt(d2)
            h0, h1, c0, c1 = dx / dc, dy / dc, -dy / d2, dx / d2
            rh0, rh1, ic0, ic1 = h0 * ir, h1 * ir, c0 * ib, c1 * ib
            j00 += rh0 * h0 + ic0 * c0
            j01 += rh0 * h1 + ic0 * c1
            j11 += rh1 * h1 + ic1 * c1
            b0 += rh0 * nr + ic0 * nb
            b1 += rh1 * nr + ic1 * nb
        # F = P Eᵀ (I + J P_pp)⁻¹
        m00, m01 = 1.0 + j00 * p00 + j01 * p01, j00 * p01 + j01 * p11
        m10, m11 = j01 * p00 + j11 * p01, 1.0 + j01 * p01 + j11 * p11
        det = m00 * m11 - m01 * m10
        i00, i01, i10, i11 = m11 / det, -m01 / det, -m10 / det, m00 / det
        f = [
            (p00 * i00 + p01 * i10, p00 * i01 + p01 * i11),
            (p01 * i00 + p11 * i10, p01 * i01 + p11 * i11),
            (p02 * i00 + p12 * i10, p02 * i01 + p12 * i11),
            (p03 * i00 + p13 * i10, p03 * i01 + p13 * i11),
        ]
        (f00, f01), (f10, f11), (f20, f21), (f30, f31) = f
        means.append(
            [x + f00 * b0 + f01 * b1, y + f10 * b0 + f11 * b1,
             vx + f20 * b0 + f21 * b1, vy + f30 * b0 + f31 * b1]
        )  # fmt: skip
        # Joseph form: T = (I − KH) P with KH = [F J, 0], then T (I − KH)ᵀ + F J Fᵀ
        g00, g01 = f00 * j00 + f01 * j01, f00 * j01 + f01 * j11
        g10, g11 = f10 * j00 + f11 * j01, f10 * j01 + f11 * j11
        g20, g21 = f20 * j00 + f21 * j01, f20 * j01 + f21 * j11
        g30, g31 = f30 * j00 + f31 * j01, f30 * j01 + f31 * j11
        t00, t01 = p00 - g00 * p00 - g01 * p01, p01 - g00 * p01 - g01 * p11
        t02, t03 = p02 - g00 * p02 - g01 * p12, p03 - g00 * p03 - g01 * p13
        t10, t11 = p01 - g10 * p00 - g11 * p01, p11 - g10 * p01 - g11 * p11
        t12, t13 = p12 - g10 * p02 - g11 * p12, p13 - g10 * p03 - g11 * p13
        t20, t21 = p02 - g20 * p00 - g21 * p01, p12 - g20 * p01 - g21 * p11
        t22, t23 = p22 - g20 * p02 - g21 * p12, p23 - g20 * p03 - g21 * p13
        t30, t31 = p03 - g30 * p00 - g31 * p01, p13 - g30 * p01 - g31 * p11
        t33 = p33 - g30 * p03 - g31 * p13
        n00 = t00 - t00 * g00 - t01 * g01 + g00 * f00 + g01 * f01
        n01 = t01 - t00 * g10 - t01 * g11 + g00 * f10 + g01 * f11
        n02 = t02 - t00 * g20 - t01 * g21 + g00 * f20 + g01 * f21
        n03 = t03 - t00 * g30 - t01 * g31 + g00 * f30 + g01 * f31
        n11 = t11 - t10 * g10 - t11 * g11 + g10 * f10 + g11 * f11
        n12 = t12 - t10 * g20 - t11 * g21 + g10 * f20 + g11 * f21
        n13 = t13 - t10 * g30 - t11 * g31 + g10 * f30 + g11 * f31
        n22 = t22 - t20 * g20 - t21 * g21 + g20 * f20 + g21 * f21
        n23 = t23 - t20 * g30 - t21 * g31 + g20 * f30 + g21 * f31
        n33 = t33 - t30 * g30 - t31 * g31 + g30 * f30 + g31 * f31
        new = [[n00, n01, n02, n03], [n01, n11, n12, n13],
               [n02, n12, n22, n23], [n03, n13, n23, n33]]  # fmt: skip
        covs.append(new)
    return np.array(means), np.array(covs)


def products_beyond_float_sums(trials: int, seed: int = 0) -> float:
    """The share of the entries of NumPy's stacked 4×4 products ``A @ B`` (random normal
    entries) equal to no plain-float sum of their four terms, in any order and in pairs."""
    import itertools

    rng = np.random.default_rng(seed)
    orders = list(itertools.permutations(range(4)))
    beyond = total = 0
    for _ in range(trials):
        a, b = rng.normal(size=(2, 3, 4, 4))
        product = (a @ b).tolist()
        for n, i, j in itertools.product(range(3), range(4), range(4)):
            terms = [a[n, i, k] * b[n, k, j] for k in range(4)]
            sums = set()
            for w, x, y, z in (tuple(terms[k] for k in order) for order in orders):
                sums.add(((w + x) + y) + z)
                sums.add((w + x) + (y + z))
            beyond += product[n][i][j] not in sums
            total += 1
    return beyond / total


#: the steps of the benchmark's episode at which the two filters are compared (the second:
#: the step timed)
FILTER_STEPS = (10, 40, 80, 160)


def filter_inputs(at: tuple[int, ...] = FILTER_STEPS) -> list[dict[str, Any]]:
    """3×3 filter steps of the benchmark's episode, after each of ``at`` steps: the estimate
    before the prediction, the robots' positions and measurements of the next tick, the team's
    filter and what the written-out one needs."""
    from resilient_tracking.belief.ekf import ExtendedKalmanFilter
    from resilient_tracking.sim.episode import EpisodeStepper

    env = make_env(SCENARIO, record=False)
    stepper = EpisodeStepper(env.session.scenario, "failure_aware", 0, record=False)
    stepper.sense()
    ekf = stepper.team.belief.estimator
    if not isinstance(ekf, ExtendedKalmanFilter):
        raise TypeError(f"{SCENARIO}'s team has no EKF ({type(ekf).__name__})")
    found = []
    for step in range(1, max(at) + 1):
        stepper.act()
        estimate = stepper.team.belief.estimates[0]
        obs = stepper.sense()
        if step not in at:
            continue
        if not np.isfinite(obs.measurements).all() or len(stepper.team.belief.leagues) != 1:
            raise RuntimeError(f"step {step} is not one of a whole team measuring every target")
        found.append(
            {
                "estimate": estimate,
                "positions": obs.positions,
                "measurements": obs.measurements,
                "ekf": ekf,
                "dt": float(ekf.model.dt),
                "process_noise": ekf.model.process_noise,
            }
        )
    return found


def written_out(given: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`filter_in_floats` of a step of :func:`filter_inputs`."""
    estimate = given["estimate"]
    return filter_in_floats(
        estimate.mean,
        estimate.cov,
        given["positions"],
        given["measurements"],
        given["dt"],
        given["process_noise"],
        given["ekf"].sensor,
    )


def largest_difference(cases: list[dict[str, Any]]) -> float:
    """The largest difference, relative to the largest entry of each, between the package's
    filter and :func:`filter_in_floats` in mean and in covariance at the steps ``cases`` of
    :func:`filter_inputs`; the benchmark stops if it is above 1e-12 (rounding apart, it is not
    the same filter)."""
    largest = 0.0
    for given in cases:
        ekf, estimate = given["ekf"], given["estimate"]
        ours = ekf.update(ekf.predict(estimate), given["positions"], given["measurements"])
        for package, floats in zip((ours.mean, ours.cov), written_out(given), strict=True):
            scale = float(np.abs(package).max())
            largest = max(largest, float(np.abs(package - floats).max()) / scale)
    if not largest <= 1e-12:
        raise RuntimeError(f"the filter in floats is {largest:.3g} (relative) from the package's")
    return largest


def _best_us(run: Callable[[], Any], calls: int, rounds: int) -> float:
    """The best CPU µs per call of ``run`` over ``rounds`` rounds of ``calls`` calls."""
    best = float("inf")
    for _ in range(rounds):
        start = time.process_time()
        for _ in range(calls):
            run()
        best = min(best, (time.process_time() - start) / calls)
    return 1e6 * best


def episode_costs(steps: int, rounds: int) -> dict[str, float]:
    """CPU µs per step of the environment (:func:`~benchmarks.env_steps.cpu_us_per_step`) and
    of the simulator alone, with the same velocities, in alternating rounds (the best of
    each)."""
    from resilient_tracking.policies.base import Decision
    from resilient_tracking.sim.episode import EpisodeStepper

    env = make_env(SCENARIO, record=False)
    actions = random_actions(env, steps)
    scenario = env.session.scenario

    def simulator() -> float:
        stepper = EpisodeStepper(scenario, "failure_aware", 0, record=False)
        modes = ["agent"] * len(scenario.robots)
        episode, start = 0, 0.0
        obs = stepper.sense()
        # as the environment is timed: 20 steps untimed, then every velocity again
        for k, action in enumerate([*actions[:WARM_UP], *actions]):
            if k == WARM_UP:
                start = time.process_time()
            u = np.asarray(action, dtype=float)
            clipped = stepper.team.config.clip(u, obs.positions)  # as the environment clips
            # valid by construction (clipped, finite): not checked again, as in the environment
            stepper.act(Decision(clipped, modes), valid=True)
            obs = stepper.sense()
            if stepper.steps_done >= scenario.steps or not obs.sensing_ok.any():  # as it resets
                episode += 1
                stepper = EpisodeStepper(scenario, "failure_aware", episode, record=False)
                obs = stepper.sense()
        return (time.process_time() - start) / steps

    best = {"environment": float("inf"), "simulator alone": float("inf")}
    for _ in range(rounds):
        best["environment"] = min(best["environment"], cpu_us_per_step(SCENARIO, steps))
        best["simulator alone"] = min(best["simulator alone"], 1e6 * simulator())
    return best


def filter_costs(calls: int, rounds: int) -> dict[str, float]:
    """CPU µs of one 3×3 filter step (prediction and update) as the package does it and
    written out in Python floats, their largest difference (:func:`largest_difference`), and a
    CasADi call's cost."""
    import casadi

    cases = filter_inputs()
    difference = largest_difference(cases)
    given = cases[1]
    ekf, estimate = given["ekf"], given["estimate"]
    positions, measurements = given["positions"], given["measurements"]

    def package() -> Any:
        return ekf.update(ekf.predict(estimate), positions, measurements)

    def floats() -> tuple[np.ndarray, np.ndarray]:
        return written_out(given)

    arguments = [
        estimate.mean.reshape(-1, 2),
        estimate.cov.reshape(-1, 2),
        positions,
        measurements.reshape(-1, 2),
    ]
    symbols = [
        casadi.SX.sym(name, *np.shape(value))
        for name, value in zip(("mean", "cov", "robots", "z"), arguments, strict=True)
    ]
    trivial = casadi.Function("trivial", symbols, [symbols[0]])
    return {
        "filter, the package's (NumPy)": _best_us(package, calls, rounds),
        "filter, written out in Python floats": _best_us(floats, calls, rounds),
        "a CasADi function's call, trivial body": _best_us(
            lambda: trivial(*arguments), calls, rounds
        ),
        "largest relative difference, floats vs package": difference,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args(argv)
    steps, calls = (300, 300) if args.quick else (3000, 3000)
    rounds = 2 if args.quick else args.rounds
    episode = episode_costs(steps, rounds)
    filters = filter_costs(calls, rounds)
    beyond = products_beyond_float_sums(50 if args.quick else 500)
    env_us, sim_us = episode["environment"], episode["simulator alone"]
    numpy_us = filters["filter, the package's (NumPy)"]
    floats_us = filters["filter, written out in Python floats"]
    # what the two episodes' steps would cost with the filter in floats (estimates)
    estimates = {
        "the environment, its filter in Python floats (estimate)": env_us - numpy_us + floats_us,
        "the simulator alone, its filter in Python floats (estimate)": sim_us
        - numpy_us
        + floats_us,
    }
    per_step = {
        "the environment (TeamEnv, record=False)": env_us,
        "the simulator alone (EpisodeStepper)": sim_us,
        **estimates,
    }
    rows: list[list[Any]] = [[name, us, 1e6 / us, us / TARGET_US] for name, us in per_step.items()]
    rows += [
        [name, filters[name], np.nan, np.nan]
        for name in (
            "filter, the package's (NumPy)",
            "filter, written out in Python floats",
            "a CasADi function's call, trivial body",
        )
    ]
    print(f"{SCENARIO}, 3×3, CPU µs per step, best of {rounds} rounds; target {TARGET_US:.0f} µs")
    print(table(rows, ["what", "µs", "per CPU second", "÷ target"]))
    print(
        "largest difference of the filter in floats from the package's, relative: "
        f"{filters['largest relative difference, floats vs package']:.3g}"
    )
    print(f"entries of NumPy's 4×4 products that no order of float sums gives: {beyond:.1%}")
    path = save(
        "env_floor",
        {
            "machine": machine(),
            "scenario": SCENARIO,
            "rounds": rounds,
            "steps": steps,
            "target_us": TARGET_US,
            "us": {**episode, **filters, **estimates},
            "products_beyond_float_sums": beyond,
        },
    )
    print(f"saved {path}")


if __name__ == "__main__":
    main()
