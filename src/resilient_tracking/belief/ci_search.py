"""The CI weights of many targets at once: SciPy's bounded scalar search, run side by side.

Covariance intersection (:mod:`~.fusion`) picks each target's weight ``λ`` by minimising
``tr P(λ)`` with ``scipy.optimize.minimize_scalar(method="bounded")`` (Brent's method: golden
sections and parabolic steps). Fusing a league's 20 targets one search at a time costs about
40 evaluations of a small inverse each, 60 ms in Python when two 40-robot leagues merge.
:func:`bounded_minimize` runs the same search for every target in lockstep, each in Python
floats with the same arithmetic in the same order, so it returns exactly SciPy's ``x`` and
``fun`` per target (``tests/test_ci_search.py`` compares them bit for bit); only the
objective's evaluations of a round are batched, one call for every search still running.
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
    step for step in Python floats (the same IEEE arithmetic in the same order); only the
    evaluations of a round are one call.
    """
    searches = [_Search(xatol) for _ in range(n)]
    first = objective(np.array([search.xf for search in searches]), np.ones(n, dtype=bool))
    for search, value in zip(searches, first, strict=True):
        search.start(float(value))
    active = [k for k, search in enumerate(searches) if search.running()]
    while active:
        x = np.array([searches[k].propose() for k in active])
        rows = np.zeros(n, dtype=bool)
        rows[active] = True
        for k, value in zip(active, objective(x, rows), strict=True):
            searches[k].tell(float(value))
        active = [k for k in active if searches[k].running() and searches[k].num < maxiter]
    return np.array([s.xf for s in searches]), np.array([s.fx for s in searches])


def _sign(v: float) -> float:
    """``np.sign(v) + (v == 0)``: 1 for ``v >= 0``, -1 below, NaN for NaN."""
    if v != v:
        return v
    return -1.0 if v < 0 else 1.0


class _Search:
    """One bounded Brent search on ``[0, 1]``, SciPy's state and steps."""

    __slots__ = (
        "a",
        "b",
        "e",
        "ffulc",
        "fnfc",
        "fulc",
        "fx",
        "nfc",
        "num",
        "rat",
        "tol1",
        "tol2",
        "x",
        "xatol",
        "xf",
        "xm",
    )

    def __init__(self, xatol: float):
        self.xatol = xatol
        self.a, self.b = 0.0, 1.0
        self.fulc = self.a + _GOLDEN * (self.b - self.a)
        self.nfc = self.xf = self.x = self.fulc
        self.rat = self.e = 0.0
        self.num = 1
        self.fx = self.ffulc = self.fnfc = 0.0
        self.xm = 0.5 * (self.a + self.b)
        self.tol1 = _SQRT_EPS * abs(self.xf) + xatol / 3.0
        self.tol2 = 2.0 * self.tol1

    def start(self, fx: float) -> None:
        self.fx = self.ffulc = self.fnfc = fx

    def running(self) -> bool:
        return abs(self.xf - self.xm) > (self.tol2 - 0.5 * (self.b - self.a))

    def propose(self) -> float:
        """The next point to evaluate (a parabolic or a golden-section step)."""
        xf, tol1 = self.xf, self.tol1
        golden = True
        if abs(self.e) > tol1:  # parabolic fit
            golden = False
            r = (xf - self.nfc) * (self.fx - self.ffulc)
            q = (xf - self.fulc) * (self.fx - self.fnfc)
            p = (xf - self.fulc) * q - (xf - self.nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            r = self.e
            self.e = self.rat
            if abs(p) < abs(0.5 * q * r) and p > q * (self.a - xf) and p < q * (self.b - xf):
                self.rat = (p + 0.0) / q
                x = xf + self.rat
                if (x - self.a) < self.tol2 or (self.b - x) < self.tol2:
                    self.rat = tol1 * _sign(self.xm - xf)
            else:
                golden = True
        if golden:
            self.e = (self.a - xf) if xf >= self.xm else (self.b - xf)
            self.rat = _GOLDEN * self.e
        self.x = xf + _sign(self.rat) * max(abs(self.rat), tol1)
        return self.x

    def tell(self, fu: float) -> None:
        """Take the value at the proposed point and shrink the bracket."""
        x, xf = self.x, self.xf
        self.num += 1
        if fu <= self.fx:
            if x >= xf:
                self.a = xf
            else:
                self.b = xf
            self.fulc, self.ffulc = self.nfc, self.fnfc
            self.nfc, self.fnfc = xf, self.fx
            self.xf, self.fx = x, fu
        else:
            if x < xf:
                self.a = x
            else:
                self.b = x
            if fu <= self.fnfc or self.nfc == xf:
                self.fulc, self.ffulc = self.nfc, self.fnfc
                self.nfc, self.fnfc = x, fu
            elif fu <= self.ffulc or self.fulc == xf or self.fulc == self.nfc:
                self.fulc, self.ffulc = x, fu
        self.xm = 0.5 * (self.a + self.b)
        self.tol1 = _SQRT_EPS * abs(self.xf) + self.xatol / 3.0
        self.tol2 = 2.0 * self.tol1
