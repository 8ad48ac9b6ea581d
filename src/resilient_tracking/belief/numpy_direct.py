"""NumPy's own C routines for the filter's per-tick linear algebra, called without the Python
wrappers of ``np.einsum`` and ``np.linalg`` (which cost more than the work on arrays of a few
numbers): the same routines, so the same numbers.

They live in NumPy's private modules (present from 1.26 to 2.4); ``tests/test_ekf.py`` and
``tests/test_numerical_health.py`` compare them with the public functions, so a NumPy that
moves or changes them fails the tests, not the results.
"""

from __future__ import annotations

import numpy as np
from numpy.linalg import _umath_linalg  # type: ignore[attr-defined]
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

try:  # what np.einsum calls when not asked to optimise
    from numpy._core.multiarray import c_einsum as einsum
except ImportError:  # NumPy 1.x
    from numpy.core.multiarray import c_einsum as einsum  # type: ignore[no-redef]

__all__ = ["cholesky_exists", "einsum", "solve"]


def solve(a: FloatArray, b: FloatArray) -> FloatArray:
    """``np.linalg.solve(a, b)`` for float64 stacks ``(N, n, n)``, ``(N, n, m)``: its LAPACK
    gufunc, called as it calls it (a singular ``a`` sets the invalid flag: ``LinAlgError``),
    without its checks of shapes and types."""
    with np.errstate(invalid="raise", over="ignore", divide="ignore", under="ignore"):
        try:
            return _umath_linalg.solve(a, b, signature="dd->d")  # type: ignore[no-any-return]
        except FloatingPointError:
            raise np.linalg.LinAlgError("Singular matrix") from None


def cholesky_exists(a: FloatArray) -> bool:
    """Whether ``np.linalg.cholesky(a)`` succeeds for the float64 stack ``a`` ``(N, d, d)``:
    its LAPACK gufunc, whose failure sets the invalid flag (the other flags ignored, as
    ``np.linalg.cholesky`` does), without its checks of shapes and types."""
    with np.errstate(invalid="raise", over="ignore", divide="ignore", under="ignore"):
        try:
            _umath_linalg.cholesky_lo(a, signature="d->d")
        except FloatingPointError:
            return False
    return True
