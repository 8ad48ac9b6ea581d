"""Adaptive weights (paper eq. 10) and the chance-constraint margins β = erfinv(1 − 2ε)."""

from __future__ import annotations

import numpy as np
from scipy.special import erf, erfinv


def adaptive_weights(
    risky: np.ndarray, safe: np.ndarray, attacked: float, total: int
) -> np.ndarray:
    """``w_s = w_s,risky − (m/M)(w_s,risky − w_s,safe)`` for ``s = 1..5`` (eq. 10), from the two
    extremes as arrays ``[w1, w2, w3, w4, w5]`` (track, effort, sensing slack, comm slack,
    clearance); ``m`` may count a robot in part (a degraded sensor, docs/model.md §6.4)."""
    r, s = risky, safe
    frac = min(max(attacked / total, 0.0), 1.0) if total else 0.0
    return r - frac * (r - s)


def chance_margin(eps: float) -> float:
    """``erfinv(1 − 2ε)``: the number of (√2-scaled) standard deviations kept at risk ``ε``."""
    return float(erfinv(1.0 - 2.0 * eps))


def risk_level(beta: np.ndarray | float) -> np.ndarray:
    """The risk level ``ε`` whose margin is ``β`` (the inverse of :func:`chance_margin`)."""
    return np.asarray((1.0 - erf(beta)) / 2.0)
