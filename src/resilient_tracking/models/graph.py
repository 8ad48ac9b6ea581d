"""Connected components of an undirected link graph (leagues, docs/model.md §1)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def components(adjacency: NDArray[np.bool_]) -> list[list[int]]:
    """Leagues from a symmetric adjacency matrix, each sorted, ordered by smallest member.

    A depth-first search over neighbour lists: teams are small, and this is called every step,
    where building a sparse matrix for a graph library cost more than the search itself.
    """
    adj = np.asarray(adjacency, dtype=bool)
    n = adj.shape[0]
    if n == 0:
        return []
    adj = adj | adj.T  # undirected: a link in either direction joins the two robots
    if (adj | np.eye(n, dtype=bool)).all():  # every pair linked: one league, the usual case
        return [list(range(n))]
    rows = adj.tolist()
    neighbours = [[j for j, linked in enumerate(row) if linked] for row in rows]
    seen = [False] * n
    groups: list[list[int]] = []
    for start in range(n):  # in increasing order, so each group starts at its smallest member
        if seen[start]:
            continue
        seen[start] = True
        stack, members = [start], [start]
        while stack:
            for j in neighbours[stack.pop()]:
                if not seen[j]:
                    seen[j] = True
                    stack.append(j)
                    members.append(j)
        groups.append(sorted(members))
    return groups
