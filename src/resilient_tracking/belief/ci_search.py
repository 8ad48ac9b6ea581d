"""The CI weights of many targets at once: SciPy's bounded scalar search, run side by side.

Covariance intersection (:mod:`~.fusion`) picks each target's weight ``λ`` by minimising
``tr P(λ)`` with ``scipy.optimize.minimize_scalar(method="bounded")`` (Brent's method: golden
sections and parabolic steps). Fusing a league's 20 targets one search at a time costs about
40 evaluations of a small inverse each, 60 ms in Python when two 40-robot leagues merge.
:func:`bounded_minimize` runs the same search for every target together, each on its own
branch (masks), with the same arithmetic in the same order, so it returns exactly SciPy's
``x`` and ``fun`` per target (``tests/test_ci_search.py`` compares them bit for bit); only
the objective's evaluations are batched.
"""

from __future__ import annotations

from collections.abc import Callable
from math import sqrt

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

_SQRT_EPS = sqrt(2.2e-16)
_GOLDEN = 0.5 * (3.0 - sqrt(5.0))


def bounded_minimize(
    objective: Callable[[FloatArray, NDArray[np.bool_]], FloatArray],
    n: int,
    xatol: float = 1e-5,
    maxiter: int = 500,
) -> tuple[FloatArray, FloatArray]:
    """Minimise ``n`` scalar functions on ``[0, 1]``; returns their minimisers and minima.

    ``objective(x, rows)`` evaluates the functions of ``rows`` (a boolean mask) at ``x``
    (one point per selected row). Each search follows SciPy's ``_minimize_scalar_bounded``
    step for step.
    """
    a, b = np.zeros(n), np.ones(n)
    every = np.ones(n, dtype=bool)
    fulc = a + _GOLDEN * (b - a)
    nfc, xf = fulc.copy(), fulc.copy()
    rat, e = np.zeros(n), np.zeros(n)
    fx = objective(xf, every)
    num = np.ones(n, dtype=int)
    ffulc, fnfc = fx.copy(), fx.copy()
    xm = 0.5 * (a + b)
    tol1 = _SQRT_EPS * np.abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    active = np.abs(xf - xm) > (tol2 - 0.5 * (b - a))
    while active.any():
        golden = active.copy()
        # parabolic fit where the last steps were long enough
        fit = active & (np.abs(e) > tol1)
        golden[fit] = False
        r = (xf - nfc) * (fx - ffulc)
        q = (xf - fulc) * (fx - fnfc)
        p = (xf - fulc) * q - (xf - nfc) * r
        q = 2.0 * (q - r)
        p = np.where(q > 0.0, -p, p)
        q = np.abs(q)
        r = np.where(fit, e, r)
        e = np.where(fit, rat, e)
        with np.errstate(divide="ignore", invalid="ignore"):
            accept = (
                fit & (np.abs(p) < np.abs(0.5 * q * r)) & (p > q * (a - xf)) & (p < q * (b - xf))
            )
            parabola = (p + 0.0) / q
        rat = np.where(accept, parabola, rat)
        x_try = xf + rat
        near_end = accept & (((x_try - a) < tol2) | ((b - x_try) < tol2))
        si_mid = np.sign(xm - xf) + ((xm - xf) == 0)
        rat = np.where(near_end, tol1 * si_mid, rat)
        golden |= fit & ~accept
        # golden-section step
        e = np.where(golden, np.where(xf >= xm, a - xf, b - xf), e)
        rat = np.where(golden, _GOLDEN * e, rat)

        si = np.sign(rat) + (rat == 0)
        x = np.where(active, xf + si * np.maximum(np.abs(rat), tol1), xf)
        fu = np.full(n, np.inf)
        fu[active] = objective(x[active], active)
        num += active

        better = active & (fu <= fx)
        worse = active & ~(fu <= fx)
        # better: shrink towards xf, shift the three points
        a = np.where(better & (x >= xf), xf, a)
        b = np.where(better & ~(x >= xf), xf, b)
        # worse: shrink towards x, keep x as a second or third point
        a = np.where(worse & (x < xf), x, a)
        b = np.where(worse & ~(x < xf), x, b)
        second = worse & ((fu <= fnfc) | (nfc == xf))
        third = worse & ~second & ((fu <= ffulc) | (fulc == xf) | (fulc == nfc))
        new_fulc = np.where(better | second, nfc, np.where(third, x, fulc))
        new_ffulc = np.where(better | second, fnfc, np.where(third, fu, ffulc))
        new_nfc = np.where(better, xf, np.where(second, x, nfc))
        new_fnfc = np.where(better, fx, np.where(second, fu, fnfc))
        xf = np.where(better, x, xf)
        fx = np.where(better, fu, fx)
        fulc, ffulc, nfc, fnfc = new_fulc, new_ffulc, new_nfc, new_fnfc

        xm = np.where(active, 0.5 * (a + b), xm)
        tol1 = np.where(active, _SQRT_EPS * np.abs(xf) + xatol / 3.0, tol1)
        tol2 = 2.0 * tol1
        active &= (num < maxiter) & (np.abs(xf - xm) > (tol2 - 0.5 * (b - a)))
    return xf, fx
