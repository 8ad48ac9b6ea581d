"""The per-step lengths are np.linalg.norm's, bit for bit (the golden tables rely on it)."""

from __future__ import annotations

import numpy as np

from resilient_tracking.models.geometry import row_norms, vector_length


def test_lengths_equal_numpys_norm_bit_for_bit():
    rng = np.random.default_rng(5)
    for shape in [(7, 2), (3, 5, 2), (4, 3)]:
        a = rng.normal(scale=10.0, size=shape)
        assert np.array_equal(row_norms(a), np.linalg.norm(a, axis=-1))
    for v in rng.normal(scale=3.0, size=(200, 2)):
        assert vector_length(v) == float(np.linalg.norm(v))
    assert vector_length(np.zeros(2)) == 0.0
