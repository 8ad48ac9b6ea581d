"""The Python-float twins of :mod:`resilient_tracking.models.numpy_twins` equal the NumPy
routines they stand for, bit for bit, on both sides of their size threshold."""

from __future__ import annotations

import numpy as np
import pytest

from resilient_tracking.models.numpy_twins import SMALL, all_finite, all_within


@pytest.mark.parametrize("size", [0, 1, 6, SMALL, SMALL + 1, 4 * SMALL])
def test_all_finite_is_numpys_elementwise_test(size: int) -> None:
    rng = np.random.default_rng(size)
    values = rng.normal(size=size)
    assert all_finite(values) is bool(np.isfinite(values).all()) is True
    if size == 0:
        return
    for bad in (np.nan, np.inf, -np.inf):
        spoiled = values.copy()
        spoiled[rng.integers(size)] = bad
        assert all_finite(spoiled) is bool(np.isfinite(spoiled).all()) is False


@pytest.mark.filterwarnings("ignore:overflow encountered")
@pytest.mark.parametrize("size", [4, 4 * SMALL])
def test_finite_terms_whose_sum_overflows_are_finite(size: int) -> None:
    values = np.full(size, np.finfo(float).max)
    assert not np.isfinite(np.add.reduce(values))  # the sum alone cannot tell
    assert all_finite(values)  # the elementwise test then does


def test_arrays_of_integers_booleans_and_no_axes() -> None:
    assert all_finite(np.arange(10)) and all_finite(np.ones(5, dtype=bool))
    assert all_finite(np.array(2.5)) and not all_finite(np.array(np.nan))
    assert all_finite(np.float32([1.0, 2.0])) and not all_finite(np.float32([1.0, np.inf]))


def test_arrays_of_any_layout_and_shape() -> None:
    stack = np.arange(48.0).reshape(3, 4, 4)
    assert all_finite(stack.swapaxes(1, 2)) and all_finite(stack[:, :2, :2])
    stack[1, 3, 0] = np.nan
    assert not all_finite(stack.swapaxes(1, 2))


def test_all_within_is_numpys_bounds_test() -> None:
    """Up to SMALL numbers the bounds test runs in Python floats; it answers as NumPy's does, at
    the tolerance's edges, NaN and ±inf, below and above the cut-off."""
    tol = 1e-6
    rng = np.random.default_rng(3)
    edges = [np.nan, np.inf, -np.inf, 1.0 + tol, -1.0 - tol, 1.0, -1.0]
    answers = set()
    for trial in range(3000):
        m = 1 + trial % (SMALL // 2 + 4)
        lower, upper = -np.ones((m, 2)), np.ones((m, 2))
        values = rng.uniform(-1.0, 1.0, size=(m, 2))
        if trial % 3:
            values.flat[rng.integers(2 * m)] = edges[trial % len(edges)]
            values.flat[rng.integers(2 * m)] += rng.choice([-1, 1]) * rng.uniform(0, 3e-6)
        expected = bool(((values >= lower - tol) & (values <= upper + tol)).all())
        assert all_within(values, lower, upper, tol) == expected
        answers.add(expected)
    assert answers == {True, False}
