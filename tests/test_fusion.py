"""Covariance intersection (docs/model.md §4): weights, optimality, consistency, per target."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.fusion import Criterion, covariance_intersection, fuse_estimates

CRITERIA: tuple[Criterion, ...] = ("trace", "det")


def _spd(rng: np.random.Generator, n: int = 4) -> np.ndarray:
    root = rng.normal(size=(n, n))
    return root @ root.T + 0.05 * np.eye(n)


def _ci_cov(p1: np.ndarray, p2: np.ndarray, lam: float) -> np.ndarray:
    return np.linalg.inv(lam * np.linalg.inv(p1) + (1 - lam) * np.linalg.inv(p2))


def _assert_psd(m: np.ndarray, tol: float = 1e-9) -> None:
    eig = np.linalg.eigvalsh(0.5 * (m + m.T))
    assert eig.min() >= -tol * max(1.0, abs(eig).max()), eig


@pytest.mark.parametrize("criterion", ["trace", "det"])
@pytest.mark.parametrize(("s1", "s2"), [(2.0, 5.0), (7.0, 5.0), (3.0, 3.0), (1.0, 1.0 + 1e-3)])
def test_scaled_identity_mean_on_segment(criterion: Criterion, s1: float, s2: float) -> None:
    rng = np.random.default_rng(0)
    y1, y2 = rng.normal(size=4), rng.normal(size=4) + 3
    mean, cov, lam = covariance_intersection(y1, s1 * np.eye(4), y2, s2 * np.eye(4), criterion)
    assert 0.0 <= lam <= 1.0
    direction = y2 - y1
    t = float(direction @ (mean - y1) / (direction @ direction))
    assert -1e-12 <= t <= 1 + 1e-12
    np.testing.assert_allclose(mean, y1 + t * direction, atol=1e-12)
    w1 = lam / s1 / (lam / s1 + (1 - lam) / s2)
    np.testing.assert_allclose(mean, w1 * y1 + (1 - w1) * y2, atol=1e-12)
    # With isotropic covariances the smaller one wins outright; equal ones give the midpoint.
    if s1 < s2:
        assert lam == 1.0
        np.testing.assert_allclose(cov, s1 * np.eye(4))
    elif s2 < s1:
        assert lam == 0.0
        np.testing.assert_allclose(cov, s2 * np.eye(4))
    else:
        np.testing.assert_allclose(mean, 0.5 * (y1 + y2))


def test_interior_lambda_symmetric_case() -> None:
    """Complementary information: each estimate is good on one axis; by symmetry λ = 1/2."""
    p1 = np.diag([1.0, 10.0, 1.0, 10.0])
    p2 = np.diag([10.0, 1.0, 10.0, 1.0])
    y1 = np.array([0.0, 0.0, 0.0, 0.0])
    y2 = np.array([2.0, 2.0, 2.0, 2.0])
    for criterion in CRITERIA:
        mean, cov, lam = covariance_intersection(y1, p1, y2, p2, criterion)
        assert lam == pytest.approx(0.5, abs=1e-5)
        np.testing.assert_allclose(cov, _ci_cov(p1, p2, lam), rtol=1e-10)
        assert np.trace(cov) < min(np.trace(p1), np.trace(p2))
        # Axis 0 is better known by estimate 1, so the fused value leans toward 0 there.
        assert 0.0 < mean[0] < 1.0 and 1.0 < mean[1] < 2.0


@pytest.mark.parametrize("criterion", ["trace", "det"])
@pytest.mark.parametrize("seed", range(25))
def test_random_pairs_properties(seed: int, criterion: Criterion) -> None:
    rng = np.random.default_rng(seed)
    p1, p2 = _spd(rng), _spd(rng)
    y1, y2 = rng.normal(size=4), rng.normal(size=4)
    mean, cov, lam = covariance_intersection(y1, p1, y2, p2, criterion)
    assert 0.0 <= lam <= 1.0
    # The returned estimate follows the CI equations at the returned λ.
    i1, i2 = np.linalg.inv(p1), np.linalg.inv(p2)
    info = lam * i1 + (1 - lam) * i2
    np.testing.assert_allclose(np.linalg.inv(cov), info, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(
        mean, np.linalg.solve(info, lam * i1 @ y1 + (1 - lam) * i2 @ y2), rtol=1e-7, atol=1e-9
    )
    np.testing.assert_allclose(cov, cov.T, atol=1e-12)
    # Never more confident than the naive fusion that assumes independence.
    naive = np.linalg.inv(i1 + i2)
    _assert_psd(cov - naive)
    # Never worse than either input, and optimal on a grid of λ.
    f = np.trace if criterion == "trace" else np.linalg.det
    assert f(cov) <= min(f(p1), f(p2)) * (1 + 1e-12)
    grid = [f(_ci_cov(p1, p2, g)) for g in np.linspace(0, 1, 201)]
    assert f(cov) <= min(grid) * (1 + 1e-7)


def test_equal_inputs_return_them() -> None:
    rng = np.random.default_rng(1)
    p, y = _spd(rng), rng.normal(size=4)
    for criterion in CRITERIA:
        mean, cov, lam = covariance_intersection(y, p, y.copy(), p.copy(), criterion)
        np.testing.assert_allclose(mean, y)
        np.testing.assert_allclose(cov, p)
        assert 0.0 <= lam <= 1.0
    # Equal covariances, different means: CI of identical uncertainty averages the means.
    mean, cov, lam = covariance_intersection(y, p, y + 1.0, p)
    np.testing.assert_allclose(mean, y + 0.5)
    np.testing.assert_allclose(cov, p)


def test_dominated_input_is_returned() -> None:
    """If P1 ⪯ P2, nothing is gained from estimate 2: λ = 1 and estimate 1 comes back."""
    rng = np.random.default_rng(2)
    p1 = _spd(rng)
    p2 = p1 + _spd(rng)
    y1, y2 = rng.normal(size=4), rng.normal(size=4)
    for criterion in CRITERIA:
        mean, cov, lam = covariance_intersection(y1, p1, y2, p2, criterion)
        assert lam == 1.0
        np.testing.assert_array_equal(mean, y1)
        np.testing.assert_array_equal(cov, p1)
        mean, cov, lam = covariance_intersection(y2, p2, y1, p1, criterion)
        assert lam == 0.0
        np.testing.assert_array_equal(cov, p1)


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="criterion"):
        bad: Any = "max"
        covariance_intersection(np.zeros(2), np.eye(2), np.ones(2), 2 * np.eye(2), bad)
    with pytest.raises(ValueError, match="shape"):
        covariance_intersection(np.zeros(2), np.eye(3), np.ones(2), np.eye(2))
    a = TargetEstimate.initial(np.zeros((2, 4)), 1.0, 1.0)
    b = TargetEstimate.initial(np.zeros((3, 4)), 1.0, 1.0)
    with pytest.raises(ValueError, match="targets"):
        fuse_estimates(a, b)


@pytest.mark.parametrize("criterion", ["trace", "det"])
def test_fuse_estimates_per_target(criterion: Criterion) -> None:
    rng = np.random.default_rng(3)
    n = 5
    a = TargetEstimate(rng.normal(size=(n, 4)), np.stack([_spd(rng) for _ in range(n)]))
    b = TargetEstimate(rng.normal(size=(n, 4)), np.stack([_spd(rng) for _ in range(n)]))
    b.cov[2] = a.cov[2] * 10.0  # target 2: a clearly better
    a_before = a.copy()
    fused, lambdas = fuse_estimates(a, b, criterion=criterion)
    assert fused.n_targets == n and lambdas.shape == (n,)
    assert lambdas[2] == 1.0
    for j in range(n):
        mean, cov, lam = covariance_intersection(
            a.mean[j], a.cov[j], b.mean[j], b.cov[j], criterion
        )
        np.testing.assert_allclose(fused.mean[j], mean)
        np.testing.assert_allclose(fused.cov[j], cov)
        assert lambdas[j] == lam
    f = np.trace if criterion == "trace" else np.linalg.det
    for j in range(n):
        assert f(fused.cov[j]) <= min(f(a.cov[j]), f(b.cov[j])) * (1 + 1e-12)
    # Inputs untouched, output does not alias them.
    np.testing.assert_array_equal(a.mean, a_before.mean)
    np.testing.assert_array_equal(a.cov, a_before.cov)
    fused.cov[2, 0, 0] += 1.0
    assert a.cov[2, 0, 0] == a_before.cov[2, 0, 0]


def test_an_attack_clue_replaces_the_maps_estimate_of_its_zone_and_nothing_else_does():
    from dataclasses import replace

    from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
    from resilient_tracking.observation import ZoneClue

    clue = ZoneClue(0, "comm", np.zeros(2), 0.09 * np.eye(2), 0.3, "permanent")
    mapped = ZoneEstimate.from_clue(clue, 0, source="broadcast")
    kb = KnowledgeBase()
    assert kb.learn(mapped)
    assert not kb.learn(replace(mapped, learned_step=4))  # the map again: nothing new
    assert kb.learn(ZoneEstimate.from_clue(clue, 7))
    assert (kb.zones["zone0"].source, kb.zones["zone0"].learned_step) == ("attack", 7)
    assert not kb.learn(mapped)  # the clue is not replaced by the map
    merged = KnowledgeBase.union([KnowledgeBase({"zone0": mapped}), kb])
    assert merged.zones["zone0"].source == "attack"


def test_a_fitted_circle_replaces_a_provisional_silence_guess_but_not_the_reverse():
    from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate

    def zone(source, step, mean=(0.0, 0.0)):
        return ZoneEstimate(
            f"{source}@{step}",
            "comm",
            np.array(mean),
            0.09 * np.eye(2),
            0.3,
            "permanent",
            source,
            step,
        )

    kb = KnowledgeBase()
    assert kb.learn(zone("silence", 1))
    assert not kb.learn(zone("silence", 2, (0.1, 0.0)))  # the same place: nothing new
    assert kb.learn(zone("circle", 5, (0.2, 0.1)))
    assert [z.source for z in kb.of_kind("comm")] == ["circle"]
    assert not kb.learn(zone("silence", 9, (0.2, 0.0)))
    assert kb.learn(zone("silence", 9, (3.0, 0.0)))  # elsewhere: a second suspect
    assert len(kb) == 2
