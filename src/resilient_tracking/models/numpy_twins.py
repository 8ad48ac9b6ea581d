"""Python-float twins of NumPy routines, for the small arrays of a step.

On an array of a few numbers a NumPy call costs more than its arithmetic. Each function here
stands beside the NumPy routine it must equal, names it, and says when the two agree bit for
bit; it works in Python floats up to :data:`SMALL` numbers and calls the routine itself
beyond. ``tests/test_numpy_twins.py`` compares each twin with its routine, so a NumPy that
computes otherwise fails the tests, not the results.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SMALL", "all_finite", "all_within"]

#: Up to this many numbers a twin works in Python floats; beyond, NumPy does.
SMALL = 64


def all_finite(values: np.ndarray) -> bool:
    """``bool(np.isfinite(values).all())``, equal for every array of real numbers.

    Up to :data:`SMALL` entries, their sum in Python floats decides when it is finite (a
    finite sum has finite terms); otherwise, or when the sum is not finite (a NaN, an infinity,
    or finite terms that overflow), NumPy's elementwise test does."""
    if values.size <= SMALL and math.isfinite(sum(values.ravel().tolist())):
        return True
    return bool(np.isfinite(values).all())


def all_within(values: np.ndarray, lower: np.ndarray, upper: np.ndarray, tol: float) -> bool:
    """``bool(((values >= lower - tol) & (values <= upper + tol)).all())`` for arrays of one
    shape, equal for every array of real numbers (a NaN is within no bounds).

    Up to :data:`SMALL` entries the same subtractions, additions and comparisons run in Python
    floats; otherwise NumPy's."""
    if (
        type(lower) is np.ndarray
        and type(upper) is np.ndarray
        and lower.shape == upper.shape == values.shape
        and values.size <= SMALL
    ):
        flat = (values.ravel().tolist(), lower.ravel().tolist(), upper.ravel().tolist())
        return all(lo - tol <= u <= hi + tol for u, lo, hi in zip(*flat, strict=True))
    lo, hi = np.subtract(lower, tol), np.add(upper, tol)
    return bool(((values >= lo) & (values <= hi)).all())
