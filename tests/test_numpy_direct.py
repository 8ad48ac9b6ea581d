"""The direct calls of NumPy's C routines (:mod:`resilient_tracking.models.numpy_direct`) give
the public functions' numbers and errors, and leave NumPy's error state as they found it."""

from __future__ import annotations

import numpy as np
import pytest

from resilient_tracking.models import numpy_direct
from resilient_tracking.models.numpy_direct import (
    IN_ORDER,
    cholesky_exists,
    einsum,
    solve,
    sum_in_order,
)

# the signatures the filter and the hazards use, with operands of their shapes
SIGNATURES = {
    "knai,kna,knaj->nij": [(3, 4, 2, 2), (3, 4, 2), (3, 4, 2, 2)],
    "knai,kna,kna->ni": [(3, 4, 2, 2), (3, 4, 2), (3, 4, 2)],
    "ij,njk,lk->nil": [(4, 4), (5, 4, 4), (4, 4)],
    "ni,ij,nj->n": [(6, 2), (2, 2), (6, 2)],
}


@pytest.mark.parametrize("signature", sorted(SIGNATURES))
def test_einsum_is_numpys_bit_for_bit(signature: str) -> None:
    rng = np.random.default_rng(7)
    for _ in range(50):
        operands = [rng.normal(size=shape) for shape in SIGNATURES[signature]]
        assert np.array_equal(einsum(signature, *operands), np.einsum(signature, *operands))


def test_solve_is_numpys_bit_for_bit_and_refuses_a_singular_stack() -> None:
    rng = np.random.default_rng(8)
    for _ in range(50):
        a = rng.normal(size=(5, 2, 2)) + 3 * np.eye(2)
        b = rng.normal(size=(5, 2, 4))
        assert np.array_equal(solve(a, b), np.linalg.solve(a, b))
    singular = np.zeros((1, 2, 2))
    with pytest.raises(np.linalg.LinAlgError):
        solve(singular, np.ones((1, 2, 1)))


def test_sum_in_order_is_numpys_sum_of_a_few_numbers_bit_for_bit() -> None:
    rng = np.random.default_rng(9)
    for n in range(IN_ORDER + 1):
        cases = [np.full(n, -0.0), np.full(n, np.inf), np.full(n, -np.inf)]
        for _ in range(500):  # magnitudes far apart: the order of the additions shows
            cases.append(rng.normal(size=n) * 10.0 ** rng.integers(-8, 8, size=n))
        for values in cases:
            ours = np.float64(sum_in_order(values.tolist())).tobytes()  # (the sign of 0 too)
            assert ours == np.add.reduce(values).tobytes()


def test_cholesky_exists_where_numpys_cholesky_succeeds() -> None:
    rng = np.random.default_rng(9)
    for _ in range(100):
        root = rng.normal(size=(3, 4, 4))
        stack = root @ root.swapaxes(1, 2) - rng.uniform(0, 3) * np.eye(4)
        try:
            np.linalg.cholesky(stack)
            expected = True
        except np.linalg.LinAlgError:
            expected = False
        assert cholesky_exists(stack) is expected


def test_the_error_state_is_left_as_it_was_found() -> None:
    with np.errstate(all="warn"):
        before = np.geterr()
        solve(np.eye(2)[None], np.ones((1, 2, 1)))
        assert not cholesky_exists(-np.eye(2)[None])
        with pytest.raises(np.linalg.LinAlgError):
            solve(np.zeros((1, 2, 2)), np.ones((1, 2, 1)))
        assert np.geterr() == before
    with np.errstate(all="ignore"):  # not the state they set: theirs raises on invalid
        with pytest.raises(np.linalg.LinAlgError):
            solve(np.zeros((1, 2, 2)), np.ones((1, 2, 1)))
        assert np.geterr() == {k: "ignore" for k in before}


def test_without_numpys_private_error_state_np_errstate_is_used(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(numpy_direct, "_extobj_contextvar", None)
    with np.errstate(all="warn"):
        before = np.geterr()
        a = np.eye(2)[None] * 2.0
        assert np.array_equal(solve(a, np.ones((1, 2, 1))), np.linalg.solve(a, np.ones((1, 2, 1))))
        assert not cholesky_exists(-np.eye(2)[None])
        with pytest.raises(np.linalg.LinAlgError):
            solve(np.zeros((1, 2, 2)), np.ones((1, 2, 1)))
        assert np.geterr() == before
