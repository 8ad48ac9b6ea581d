"""Whether every number of an array is finite, decided quickly for the small arrays of a tick."""

from __future__ import annotations

import math

import numpy as np

#: Up to this many entries, the sum is taken in Python floats (quicker than a NumPy call on a
#: few numbers); beyond it, by NumPy.
SMALL = 64


def all_finite(values: np.ndarray) -> bool:
    """Whether every entry of the array ``values`` is finite: by :func:`sum_is_finite` in the
    usual case, by the elementwise test only when the sum is not finite (a NaN, an infinity,
    or finite terms that overflow)."""
    return sum_is_finite(values) or bool(np.isfinite(values).all())


def sum_is_finite(values: np.ndarray) -> bool:
    """Whether the sum of the entries of ``values`` is finite; a finite sum has finite terms,
    so ``True`` means every entry is finite (``False``: some entry may not be)."""
    if values.size <= SMALL:
        return math.isfinite(sum(values.ravel().tolist()))
    return math.isfinite(np.add.reduce(values, axis=None))
