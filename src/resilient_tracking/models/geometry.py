"""Lengths on the per-step path: the very operations of ``np.linalg.norm`` (so the same bits),
without its argument handling, which costs more than the sums for the small arrays here."""

from __future__ import annotations

import math

import numpy as np


def row_norms(a: np.ndarray) -> np.ndarray:
    """Euclidean length over the last axis, ``√(Σ a²)``, as ``np.linalg.norm(a, axis=-1)``."""
    return np.sqrt((a * a).sum(axis=-1))


def vector_length(v: np.ndarray) -> float:
    """Euclidean length of one vector, ``√(v·v)``, as ``np.linalg.norm(v)``."""
    return math.sqrt(v.dot(v))
