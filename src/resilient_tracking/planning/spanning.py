"""Which teammate links a league's comm-zone constraints protect (route program option).

Eq. 7d keeps robot ``i`` outside the region where a comm zone would jam its link to a
teammate ``j`` (``‖x_i − x_C‖ ≤ δ2 ‖x_i − x_j‖``). Written for every teammate, as in the
paper, a league spread over several metres must keep a wide area clear. A league stays
connected as long as the links of one spanning tree hold, so the route program can protect
just the links of the shortest (Euclidean) spanning tree of the league's current positions.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import minimum_spanning_tree

#: added to every distance so that coinciding robots still get an edge (csgraph drops zeros)
_TIE = 1e-9


def spanning_unlinked(positions: np.ndarray) -> np.ndarray:
    """``(n, n)`` 1.0 where a pair is *not* an edge of the shortest spanning tree of
    ``positions`` (the diagonal included), 0.0 on the tree's edges, both ways."""
    n = len(positions)
    if n < 2:
        return np.ones((n, n))
    gaps = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=2)
    tree = minimum_spanning_tree(gaps + _TIE * (1 - np.eye(n))).toarray() > 0
    return 1.0 - (tree | tree.T).astype(float)
