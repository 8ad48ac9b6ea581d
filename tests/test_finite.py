"""The quick finiteness tests of :mod:`resilient_tracking.models.finite` agree with NumPy's
elementwise test, small arrays and large, including sums that overflow."""

from __future__ import annotations

import numpy as np
import pytest

from resilient_tracking.models.finite import SMALL, all_finite, sum_is_finite


@pytest.mark.parametrize("size", [0, 1, 6, SMALL, SMALL + 1, 4 * SMALL])
def test_all_finite_is_numpys_elementwise_test(size: int) -> None:
    rng = np.random.default_rng(size)
    values = rng.normal(size=size)
    assert all_finite(values) and sum_is_finite(values)
    if size == 0:
        return
    for bad in (np.nan, np.inf, -np.inf):
        spoiled = values.copy()
        spoiled[rng.integers(size)] = bad
        assert not all_finite(spoiled)
        assert not sum_is_finite(spoiled)


@pytest.mark.filterwarnings("ignore:overflow encountered")
@pytest.mark.parametrize("size", [4, 4 * SMALL])
def test_finite_terms_whose_sum_overflows_are_finite(size: int) -> None:
    values = np.full(size, np.finfo(float).max)
    assert not sum_is_finite(values)  # the sum alone cannot tell
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
