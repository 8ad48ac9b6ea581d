"""Connected components of an undirected link graph (leagues, SPEC §1)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components


def components(adjacency: NDArray[np.bool_]) -> list[list[int]]:
    """Leagues from a symmetric adjacency matrix, each sorted, ordered by smallest member."""
    n = adjacency.shape[0]
    if n == 0:
        return []
    _, labels = connected_components(csr_matrix(adjacency.astype(np.int8)), directed=False)
    groups: dict[int, list[int]] = {}
    for robot, label in enumerate(labels):
        groups.setdefault(int(label), []).append(robot)
    return sorted(groups.values(), key=lambda g: g[0])
