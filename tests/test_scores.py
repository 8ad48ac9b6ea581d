"""The run scores that judge an estimate with its own covariance (NEES, NLL, the ANEES band)
agree with independent implementations: SciPy's Gaussian, the Mahalanobis distance of SciPy and
of Stone Soup, the χ² distribution and a Monte Carlo of consistent errors; and a run's tables
and summary hold those numbers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import mahalanobis
from scipy.stats import chi2, multivariate_normal, norm
from stonesoup.measures import Mahalanobis
from stonesoup.types.state import GaussianState, State

from helpers import shipped
from resilient_tracking.experiments.summary import summarise_run
from resilient_tracking.runs.metrics import anees_band, position_nees, position_nll, step_scores
from resilient_tracking.runs.reading import run_data
from resilient_tracking.sim.episode import run_episode


def random_spd(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` random 2×2 covariances: scales from 1e-4 to 1e2, correlations up to ±0.99."""
    std = 10.0 ** rng.uniform(-2, 1, size=(n, 2))
    rho = rng.uniform(-0.99, 0.99, size=n)
    cov = np.empty((n, 2, 2))
    cov[:, 0, 0], cov[:, 1, 1] = std[:, 0] ** 2, std[:, 1] ** 2
    cov[:, 0, 1] = cov[:, 1, 0] = rho * std[:, 0] * std[:, 1]
    return cov


def test_nees_and_nll_are_scipys_mahalanobis_and_gaussian_log_density() -> None:
    rng = np.random.default_rng(11)
    n = 500
    cov = random_spd(rng, n)
    truth = rng.normal(scale=5.0, size=(n, 2))
    # errors of every size against their covariance: 0.01 to 100 standard deviations
    root = np.linalg.cholesky(cov)
    error = (root @ rng.normal(size=(n, 2, 1)))[..., 0] * 10.0 ** rng.uniform(-2, 2, (n, 1))
    estimated = truth + error
    nees = position_nees(error, cov)
    nll = position_nll(error, cov)
    for j in range(n):
        expected_nees = mahalanobis(truth[j], estimated[j], np.linalg.inv(cov[j])) ** 2
        expected_nll = -multivariate_normal(estimated[j], cov[j]).logpdf(truth[j])
        assert nees[j] == pytest.approx(expected_nees, rel=1e-9)
        assert nll[j] == pytest.approx(expected_nll, rel=1e-9, abs=1e-9)
    mean_nll, mean_nees = step_scores(estimated, truth, cov)
    assert mean_nll == pytest.approx(nll.mean(), rel=1e-12)
    assert mean_nees == pytest.approx(nees.mean(), rel=1e-12)


def test_nees_is_the_square_of_stone_soups_mahalanobis_distance() -> None:
    rng = np.random.default_rng(12)
    n = 200
    cov = random_spd(rng, n)
    truth = rng.normal(scale=5.0, size=(n, 2))
    error = rng.normal(size=(n, 2)) * np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    nees = position_nees(error, cov)
    measure = Mahalanobis()
    for j in range(n):
        estimate = GaussianState((truth[j] + error[j])[:, None], cov[j])
        distance = measure(estimate, State(truth[j][:, None]))
        assert nees[j] == pytest.approx(distance**2, rel=1e-9)


@pytest.mark.parametrize("samples", [1, 3, 40, 900])
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_anees_band_holds_the_chi2_quantiles_of_the_mean_nees(samples: int, dim: int) -> None:
    """The band's ends are where χ²(dim·samples) puts 2.5 % and 97.5 % of ``samples`` times
    the mean; from 40 degrees of freedom on they are the Wilson–Hilferty approximation's
    ``k (1 − 2/(9k) ± 1.96 √(2/(9k)))³ / samples`` (``k = dim·samples``) to within 0.05 %."""
    low, high = anees_band(samples, dim=dim)
    dof = dim * samples
    assert chi2.cdf(low * samples, dof) == pytest.approx(0.025, abs=1e-9)
    assert chi2.cdf(high * samples, dof) == pytest.approx(0.975, abs=1e-9)
    assert low < dim < high
    if dof >= 40:
        a = 2.0 / (9.0 * dof)
        for end, z in ((low, norm.ppf(0.025)), (high, norm.ppf(0.975))):
            assert end == pytest.approx(dof * (1.0 - a + z * np.sqrt(a)) ** 3 / samples, rel=5e-4)
    low99, high99 = anees_band(samples, level=0.99, dim=dim)
    assert low99 < low and high < high99


def test_anees_band_needs_a_sample() -> None:
    with pytest.raises(ValueError, match="at least one sample"):
        anees_band(0)


@pytest.mark.parametrize("samples", [1, 10, 150])
def test_the_anees_of_consistent_errors_falls_in_the_band_95_percent_of_the_time(
    samples: int,
) -> None:
    """Errors drawn from their own covariances (random, one per sample): the ANEES of
    ``samples`` of them lies in the 95 % band in 95 % of 20 000 trials (binomial error
    0.15 %: 4 of them allowed)."""
    rng = np.random.default_rng(13 + samples)
    trials = 20_000
    cov = random_spd(rng, trials * samples)
    error = (np.linalg.cholesky(cov) @ rng.normal(size=(trials * samples, 2, 1)))[..., 0]
    anees = position_nees(error, cov).reshape(trials, samples).mean(axis=1)
    low, high = anees_band(samples)
    inside = np.mean((low <= anees) & (anees <= high))
    assert abs(inside - 0.95) < 4 * np.sqrt(0.95 * 0.05 / trials)
    # and each tail holds its 2.5 %
    assert abs(np.mean(anees < low) - 0.025) < 4 * np.sqrt(0.025 * 0.975 / trials)


@pytest.mark.parametrize("name", ["sensing-temp", "ncv-sensing"])
def test_a_runs_nll_and_nees_are_those_of_its_targets_table_and_its_summary_their_means(
    name: str,
) -> None:
    """Per step, the team table's ``nll`` and ``nees`` are the mean over targets of SciPy's
    Gaussian and Mahalanobis numbers of the targets table's truth, estimate and covariance;
    the summary's ``mse``, ``nll`` and ``anees`` are the means of the team table."""
    result = run_episode(shipped(name).with_overrides(steps=40), seed=4)
    team, targets = result["team"], result["targets"].sort_values(["step", "target"])
    n_targets = targets["target"].nunique()
    assert len(targets) == len(team) * n_targets
    expected = {"mse": [], "nll": [], "nees": []}
    for _, rows in targets.groupby("step", sort=True):
        nll, nees, sq = [], [], []
        for row in rows.itertuples():
            truth, est = np.array([row.x, row.y]), np.array([row.est_x, row.est_y])
            cov = np.array([[row.var_x, row.cov_xy], [row.cov_xy, row.var_y]])
            nll.append(-multivariate_normal(est, cov).logpdf(truth))
            nees.append(mahalanobis(truth, est, np.linalg.inv(cov)) ** 2)
            sq.append(float(np.sum((est - truth) ** 2)))
        for key, values in zip(("nll", "nees", "mse"), (nll, nees, sq), strict=True):
            expected[key].append(np.mean(values))
    for key, values in expected.items():
        np.testing.assert_allclose(team[key].to_numpy(), values, rtol=1e-9, atol=1e-9)
    summary = summarise_run(run_data(result))
    assert summary["mse"] == pytest.approx(team["mse"].mean(), rel=1e-12)
    assert summary["nll"] == pytest.approx(team["nll"].mean(), rel=1e-12)
    assert summary["anees"] == pytest.approx(team["nees"].mean(), rel=1e-12)
    low, high = anees_band(len(team) * n_targets)
    assert (summary["anees_low"], summary["anees_high"]) == (low, high)
    assert summary["anees_in_band"] == (low <= summary["anees"] <= high)
