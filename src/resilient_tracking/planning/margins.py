"""Keep-out margins of the chance constraints (paper eqs. 7c and 7d), in one place.

For a robot at ``x⁺`` and a zone estimate ``N(μ, Σ)`` the margin is::

    h(x⁺) = D(x⁺, μ) − offset − β √(2 âᵀ Σ â + ε_s),   D(x⁺, μ) = √(‖μ − x⁺‖² + ε²)

with ``â = (μ − x⁺) / D`` and ``β = erfinv(1 − 2ε)``; ``offset`` is ``r_safe`` for a sensing
zone (eq. 7c) and the extra clearance of a comm zone (eq. 7d), whose row also subtracts
``δ2 ρ(x_i⁺ − x_q⁺)`` for each teammate, ``ρ(v) = √(‖v‖² + ε²)``. The regularisations ``ε``
(``PLAN_EPS``) and ``ε_s`` (``SPREAD_EPS``) keep the margin differentiable everywhere.

**The zone's core.** The paper's ``â`` is a unit vector; regularised, ``‖â‖² = 1 − ε²/D²``
shrinks to 0 at the zone's mean, and with it the spread term. Alone, that makes the mean a
sharp local maximum of ``h``: a robot inside a known zone, near its mean, would reduce its
violation by moving *to* the mean, where the margin has a kink that no Newton step converges
on. Within the zone's core (radius ``r_c``, :func:`_core`) the spread is therefore completed
with the direction-averaged variance ``m = tr Σ / 2`` for the missing length::

    âᵀΣâ  →  âᵀΣâ + w(‖μ − x⁺‖) (1 − ‖â‖²) m,   w(r) = max(0, 1 − r²/r_c²)³

(``w`` is twice differentiable and exactly 0 from ``r_c`` on, where the margin is the one
above to the bit). For an isotropic ``Σ`` the margin then rises with the distance from the
mean everywhere; as ``w (1 − ‖â‖²) m ≤ (1 − ‖â‖²) λ_max``, the bound of
:func:`keep_out_lower_bound` still holds.

The same margin three ways, side by side: symbolic (:func:`keep_out`, :func:`pair_distance`)
for the NLP, numeric (:func:`keep_out_values`, :func:`pair_distances`) for the safe action,
and a lower bound over a disc of reachable positions (:func:`keep_out_lower_bound`) for the
SQP's reduced problem. ``tests/test_margins.py`` checks that they agree.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from resilient_tracking.models.sensor import PLAN_EPS

#: Keeps √(2 âᵀΣâ) differentiable where â vanishes (a robot exactly on a zone's mean).
SPREAD_EPS = 1e-9
#: Smallest radius (m) of a zone's core (the module docstring): 2 ``PLAN_EPS``.
CORE_MIN = 2 * PLAN_EPS


def _core(square: Any, mean_variance: Any, beta: Any) -> Any:
    """``2 w(r) (1 − ‖â‖²) m`` at ``r² = square`` for the spread's completion in the zone's core,
    NumPy or CasADi; exactly 0 from the core's radius on.

    Without it the margin falls from the mean out to ``r*``, the root of ``r (r² + ε²) = k``,
    ``k = β √(2m) ε²``; the core's radius ``r_c = max(2ε, 1.5 k^(1/3)) ≥ 1.5 r*`` is where the
    completed isotropic margin rises everywhere (``tests/test_margins.py``)."""
    numeric = isinstance(square, np.ndarray)
    lib: Any = np if numeric else ca
    fmax = np.maximum if numeric else ca.fmax
    k = fmax(beta, 0.0) * lib.sqrt(2 * fmax(mean_variance, 0.0)) * PLAN_EPS**2
    radius = fmax(CORE_MIN, 1.5 * (np.cbrt(k) if numeric else k ** (1 / 3)))
    w = fmax(0.0, 1.0 - square / radius**2) ** 3
    return 2 * w * (PLAN_EPS**2 / (square + PLAN_EPS**2)) * mean_variance


# ---------------------------------------------------------------------------- symbolic


def _unit_and_norm(v: Any) -> tuple[Any, Any]:
    norm = ca.sqrt(ca.sumsqr(v) + PLAN_EPS**2)
    return v / norm, norm


def _quad(a: Any, sxx: Any, sxy: Any, syy: Any) -> Any:
    return a[0] * a[0] * sxx + 2 * a[0] * a[1] * sxy + a[1] * a[1] * syy


def keep_out(xp: Any, gaussian: Any, offset: Any, beta: Any) -> Any:
    """``h(x⁺)`` for a zone's ``gaussian`` (mean, then covariance xx, xy, yy), symbolic."""
    v = gaussian[0:2] - xp
    ahat, dist = _unit_and_norm(v)
    core = _core(ca.sumsqr(v), 0.5 * (gaussian[2] + gaussian[4]), beta)
    spread = ca.sqrt(2 * _quad(ahat, gaussian[2], gaussian[3], gaussian[4]) + core + SPREAD_EPS)
    return dist - offset - beta * spread


def pair_distance(xp: Any, xq: Any) -> Any:
    """``ρ(x_p − x_q)``, the regularised distance between two robots, symbolic."""
    return ca.sqrt(ca.sumsqr(xp - xq) + PLAN_EPS**2)


# ---------------------------------------------------------------------------- numeric


def keep_out_values(
    x: np.ndarray, gaussians: np.ndarray, offset: np.ndarray, beta: np.ndarray
) -> np.ndarray:
    """``h(x)`` of one position ``x`` (2,) for each zone row of ``gaussians`` (L, ≥ 5)."""
    g = np.asarray(gaussians, dtype=float)
    v = g[:, 0:2] - np.asarray(x, dtype=float)
    square = v[:, 0] ** 2 + v[:, 1] ** 2
    dist = np.sqrt(square + PLAN_EPS**2)
    a = v / dist[:, None]
    quad = (
        a[:, 0] * a[:, 0] * g[:, 2] + 2 * a[:, 0] * a[:, 1] * g[:, 3] + a[:, 1] * a[:, 1] * g[:, 4]
    )
    core = _core(square, 0.5 * (g[:, 2] + g[:, 4]), np.asarray(beta, dtype=float))
    return np.asarray(dist - offset - beta * np.sqrt(2 * quad + core + SPREAD_EPS))


def pair_distances(x: np.ndarray, others: np.ndarray) -> np.ndarray:
    """``ρ(x − x_q)`` for each row of ``others``."""
    v = np.asarray(others, dtype=float).reshape(-1, 2) - np.asarray(x, dtype=float)
    return np.asarray(np.sqrt(v[:, 0] ** 2 + v[:, 1] ** 2 + PLAN_EPS**2))


def largest_variance(gaussians: np.ndarray) -> np.ndarray:
    """``λ_max`` of each zone row's covariance (entries xx, xy, yy in columns 2–4)."""
    xx, xy, yy = gaussians[:, 2], gaussians[:, 3], gaussians[:, 4]
    return np.asarray(0.5 * (xx + yy) + np.hypot(0.5 * (xx - yy), xy))


def keep_out_lower_bound(
    x: np.ndarray, reach: np.ndarray, gaussians: np.ndarray, offset: np.ndarray, beta: np.ndarray
) -> np.ndarray:
    """``(robots, zones)``: a lower bound of ``h`` over the disc of radius ``reach[i]`` around
    each robot position ``x[i]``.

    ``D(x⁺, μ) ≥ √(max(‖μ − x_i‖ − r_i, 0)² + ε²)`` over the disc and, as ``‖â‖ < 1``,
    ``0 ≤ √(2 âᵀΣâ + ε_s) ≤ √(2 max(λ_max(Σ), 0) + ε_s)``, so ``β`` times it is at most
    ``max(β, 0) √(2 max(λ_max(Σ), 0) + ε_s)``.
    """
    z = gaussians
    gap = np.hypot(z[:, 0] - x[:, :1], z[:, 1] - x[:, 1:]) - reach[:, None]
    top = largest_variance(z)
    spread = np.sqrt(2 * np.maximum(top, 0.0) + SPREAD_EPS)
    return np.sqrt(np.maximum(gap, 0.0) ** 2 + PLAN_EPS**2) - offset - np.maximum(beta, 0) * spread


def pair_distance_upper_bound(distance: np.ndarray) -> np.ndarray:
    """``ρ`` at a distance that bounds ``‖x_i⁺ − x_q⁺‖`` from above: an upper bound of ``ρ``."""
    return np.asarray(np.sqrt(distance**2 + PLAN_EPS**2))
