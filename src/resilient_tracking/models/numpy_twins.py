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

__all__ = ["SMALL", "all_finite"]

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
