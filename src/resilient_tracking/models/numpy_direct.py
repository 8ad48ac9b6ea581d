"""NumPy's own C routines for the per-tick linear algebra of the filter and the hazards, called
without the Python wrappers of ``np.einsum`` and ``np.linalg``.

Those wrappers cost more than the work on arrays of a few numbers. This module calls the same
C routines directly, so the numbers are the same: ``np.einsum``'s ``c_einsum``, and
``np.linalg``'s LAPACK gufuncs under the error state that ``np.errstate`` would set (made once,
not at every call). They live in NumPy's private modules (present from 1.26 to 2.4);
``tests/test_numpy_direct.py`` compares them with the public functions, so a NumPy that moves or
changes them fails the tests, not the results. The filter (:mod:`~resilient_tracking.belief`)
and the hazards' density (:mod:`~resilient_tracking.world.hazards`) use them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.linalg import _umath_linalg  # type: ignore[attr-defined]
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

try:  # what np.einsum calls when not asked to optimise
    from numpy._core.multiarray import c_einsum as einsum
except ImportError:  # NumPy 1.x
    from numpy.core.multiarray import c_einsum as einsum  # type: ignore[no-redef]

# The error state np.errstate(invalid="raise", over="ignore", divide="ignore", under="ignore")
# sets, made once at import (np.errstate makes it at each entry). Its error callback and buffer
# size are those in force at import: no flag here calls the callback, and the buffer size
# changes no number.
try:
    from numpy._core._ufunc_config import (  # type: ignore[attr-defined]
        _extobj_contextvar,
        _make_extobj,
    )

    _RAISE_INVALID = _make_extobj(invalid="raise", over="ignore", divide="ignore", under="ignore")
except Exception:  # another NumPy: np.errstate itself
    _extobj_contextvar = _RAISE_INVALID = None

__all__ = ["IN_ORDER", "cholesky_exists", "einsum", "solve", "sum_in_order"]

#: NumPy sums up to this many float64 numbers one after another, onto 0.0; more, pairwise
#: (:func:`sum_in_order`).
IN_ORDER = 7


def solve(a: FloatArray, b: FloatArray) -> FloatArray:
    """``np.linalg.solve(a, b)`` for float64 stacks ``(N, n, n)``, ``(N, n, m)``: its LAPACK
    gufunc, called as it calls it (a singular ``a`` sets the invalid flag: ``LinAlgError``),
    without its checks of shapes and types."""
    token = _raise_invalid()
    try:
        return _umath_linalg.solve(a, b, signature="dd->d")  # type: ignore[no-any-return]
    except FloatingPointError:
        raise np.linalg.LinAlgError("Singular matrix") from None
    finally:
        _restore(token)


def cholesky_exists(a: FloatArray) -> bool:
    """Whether ``np.linalg.cholesky(a)`` succeeds for the float64 stack ``a`` ``(N, d, d)``:
    its LAPACK gufunc, whose failure sets the invalid flag (the other flags ignored, as
    ``np.linalg.cholesky`` does), without its checks of shapes and types."""
    token = _raise_invalid()
    try:
        _umath_linalg.cholesky_lo(a, signature="d->d")
    except FloatingPointError:
        return False
    finally:
        _restore(token)
    return True


def sum_in_order(values: list[float]) -> float:
    """``np.add.reduce``'s sum of up to :data:`IN_ORDER` float64 numbers, given as Python
    floats: each added in turn onto 0.0, the same IEEE additions in the same order (so a sum of
    −0.0s is 0.0, as NumPy's), without a NumPy call. More numbers NumPy sums pairwise: not for
    this function. ``tests/test_numpy_direct.py`` checks it against NumPy, bit for bit, so a
    NumPy that sums otherwise fails the tests, not the results."""
    total = 0.0
    for value in values:
        total += value
    return total


def _raise_invalid() -> Any:
    """Enter ``np.errstate(invalid="raise", over="ignore", divide="ignore", under="ignore")``
    (its state, made once); what it returns is for :func:`_restore`, in a local variable (the
    state is per thread: nothing shared is written)."""
    if _extobj_contextvar is None:
        state = np.errstate(invalid="raise", over="ignore", divide="ignore", under="ignore")
        state.__enter__()
        return state
    return _extobj_contextvar.set(_RAISE_INVALID)


def _restore(token: Any) -> None:
    """Leave the error state that :func:`_raise_invalid` entered."""
    if isinstance(token, np.errstate):
        token.__exit__(None, None, None)
    else:
        _extobj_contextvar.reset(token)
