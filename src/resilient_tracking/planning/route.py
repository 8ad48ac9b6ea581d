"""Shortest routes in the plane around known keep-out discs.

The one-step program of the paper (eq. 7) sees one step ahead only: a known zone between a
robot and its target is a local minimum, and far from its targets a robot gains less tracking
per step than it pays in effort. The route planner gives each robot a *cost-to-go*: the length
of the shortest route to its goal that stays out of every known keep-out disc.

Routes are found on a visibility graph. Each disc is replaced by a regular polygon that
circumscribes it (slightly inflated), so a straight edge between two polygon corners that
misses every disc is a feasible path; the shortest route between two points is then a
shortest path in the graph of mutually visible corners (Lozano-Pérez & Wesley, 1979), within
a factor ``1/cos(π/sides)`` of the true shortest route around the discs.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
from scipy.sparse.csgraph import dijkstra

#: Corners of the polygon that replaces each disc.
SIDES = 16
#: Clearance (m) added to each disc before its polygon is drawn.
INFLATE = 0.05
#: A segment passing a disc's center closer than ``radius - TOUCH`` is blocked by it.
TOUCH = 1e-6


def segment_distances(starts: np.ndarray, ends: np.ndarray, centers: np.ndarray) -> np.ndarray:
    """Distance from each center to each segment ``starts[e] → ends[e]``: shape (E, K)."""
    d = ends - starts  # (E, 2)
    rel = centers[None, :, :] - starts[:, None, :]  # (E, K, 2)
    length2 = np.maximum(np.einsum("ei,ei->e", d, d), 1e-300)
    t = np.clip(np.einsum("eki,ei->ek", rel, d) / length2[:, None], 0.0, 1.0)
    closest = starts[:, None, :] + t[..., None] * d[:, None, :]
    return np.linalg.norm(centers[None, :, :] - closest, axis=2)


def pair_distances(starts: np.ndarray, ends: np.ndarray, centers: np.ndarray) -> np.ndarray:
    """Distance from ``centers[p]`` to the segment ``starts[p] → ends[p]``: shape (P,), the
    same numbers as :func:`segment_distances` gives for those pairs."""
    d = ends - starts
    rel = centers - starts
    length2 = np.maximum(np.einsum("ei,ei->e", d, d), 1e-300)
    t = np.clip(np.einsum("ei,ei->e", rel, d) / length2, 0.0, 1.0)
    closest = starts + t[:, None] * d
    return np.linalg.norm(centers - closest, axis=1)


class RouteMap:
    """Keep-out discs ``(x, y, radius)`` in a workspace box, and routes around them."""

    def __init__(
        self,
        discs: np.ndarray,
        lower: np.ndarray,
        upper: np.ndarray,
        sides: int = SIDES,
        inflate: float = INFLATE,
    ):
        self.discs = np.asarray(discs, dtype=float).reshape(-1, 3)
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        centers, radii = self.discs[:, :2], self.discs[:, 2]
        angles = 2 * np.pi * np.arange(sides) / sides
        ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        corner_radius = (radii + inflate) / np.cos(np.pi / sides)
        corners = (centers[:, None, :] + corner_radius[:, None, None] * ring[None]).reshape(-1, 2)
        inside_box = np.all((corners >= self.lower) & (corners <= self.upper), axis=1)
        inside_disc = self._inside(corners).any(axis=1)
        self.corners = corners[inside_box & ~inside_disc]
        n = len(self.corners)
        edges = np.full((n, n), np.inf)
        if n:
            a = np.repeat(self.corners, n, axis=0)
            b = np.tile(self.corners, (n, 1))
            free = self._free(a, b, np.zeros((n * n, len(self.discs)), dtype=bool))
            lengths = np.linalg.norm(a - b, axis=1)
            edges = np.where(free, lengths, np.inf).reshape(n, n)
        #: (C, C) shortest paths between corners (dense input: ``inf`` marks no edge)
        self._between = dijkstra(edges, directed=False) if n else edges

    # ------------------------------------------------------------------ geometry

    def _inside(self, points: np.ndarray) -> np.ndarray:
        """(P, K): point p lies inside disc k."""
        gaps = np.linalg.norm(points[:, None, :] - self.discs[None, :, :2], axis=2)
        return gaps < self.discs[None, :, 2] - TOUCH

    def _free(self, a: np.ndarray, b: np.ndarray, ignore: np.ndarray) -> np.ndarray:
        """Segments ``a[e] → b[e]`` that cross no disc, skipping ``ignore[e, k]`` pairs."""
        if not len(self.discs):
            return np.ones(len(a), dtype=bool)
        centers, radii = self.discs[:, :2], self.discs[:, 2]
        # only a disc whose centre lies in the segment's bounding box grown by the radius can
        # block it (grown by a little less than the radius: a disc outside is at least
        # ``radius - TOUCH / 2`` away, beyond rounding of the exact test below)
        grow = radii - TOUCH / 2
        low, high = np.minimum(a, b), np.maximum(a, b)
        candidate = ~ignore
        for axis in (0, 1):
            candidate &= low[:, None, axis] < centers[None, :, axis] + grow
            candidate &= high[:, None, axis] > centers[None, :, axis] - grow
        e, k = np.nonzero(candidate)
        near = pair_distances(a[e], b[e], centers[k]) < radii[k] - TOUCH
        free = np.ones(len(a), dtype=bool)
        free[e[near]] = False
        return free

    def _sight(self, points: np.ndarray) -> np.ndarray:
        """(P, C): corner c is in sight of point p; a disc that holds p does not block it."""
        n_p, n_c = len(points), len(self.corners)
        if not n_c:
            return np.zeros((n_p, 0), dtype=bool)
        holding = np.repeat(self._inside(points), n_c, axis=0)
        a = np.repeat(points, n_c, axis=0)
        b = np.tile(self.corners, (n_p, 1))
        return self._free(a, b, holding).reshape(n_p, n_c)

    def _direct(self, starts: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """(S, G): the straight segment from start s to goal g is free."""
        n_s, n_g = len(starts), len(goals)
        ignore = np.repeat(self._inside(starts), n_g, axis=0) | np.tile(
            self._inside(goals), (n_s, 1)
        )
        a = np.repeat(starts, n_g, axis=0)
        b = np.tile(goals, (n_s, 1))
        return self._free(a, b, ignore).reshape(n_s, n_g)

    def _direct_pairs(self, starts: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """(S,): the straight segment from start s to goal s is free."""
        ignore = self._inside(starts) | self._inside(goals)
        return self._free(starts, goals, ignore)

    def outside(self, points: np.ndarray) -> np.ndarray:
        """``points`` (P, 2) pushed radially out of every disc that holds them (a few passes),
        then clipped to the workspace: where to stand near a goal that lies inside a zone."""
        p = np.array(points, dtype=float).reshape(-1, 2)
        for _ in range(3):
            inside = self._inside(p)
            if not inside.any():
                break
            for k in np.flatnonzero(inside.any(axis=0)):
                rows = inside[:, k]
                center, radius = self.discs[k, :2], self.discs[k, 2]
                away = p[rows] - center
                norm = np.linalg.norm(away, axis=1, keepdims=True)
                unit = np.where(norm > 1e-9, away / np.maximum(norm, 1e-9), [1.0, 0.0])
                p[rows] = center + unit * (radius + INFLATE)
        return np.clip(p, self.lower, self.upper)

    # ------------------------------------------------------------------ routes

    def _to_goals(self, goals: np.ndarray) -> np.ndarray:
        """(G, C): route length from every corner to every goal."""
        n_c = len(self.corners)
        if not n_c:
            return np.zeros((len(goals), 0))
        lengths = np.linalg.norm(goals[:, None, :] - self.corners[None], axis=2)
        last_leg = np.where(self._sight(goals), lengths, np.inf)  # (G, C)
        # corner c to goal g: along the graph to the best last corner v, then straight to g
        return np.min(last_leg[:, :, None] + self._between[None, :, :], axis=1)

    def _first_legs(self, starts: np.ndarray) -> np.ndarray:
        """(S, C): straight distance from each start to each corner in its sight, else inf."""
        gaps = np.linalg.norm(starts[:, None, :] - self.corners[None], axis=2)
        return np.where(self._sight(starts), gaps, np.inf)

    def lengths(self, starts: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """(S, G): shortest route lengths (``inf`` where no route exists)."""
        starts = np.asarray(starts, dtype=float).reshape(-1, 2)
        goals = np.asarray(goals, dtype=float).reshape(-1, 2)
        straight = np.linalg.norm(starts[:, None, :] - goals[None, :, :], axis=2)
        direct = self._direct(starts, goals)
        if direct.all() or not len(self.corners):
            return np.where(direct, straight, np.inf)
        # around the discs only from the starts, and to the goals, of a blocked pair
        rows, cols = np.flatnonzero(~direct.all(axis=1)), np.flatnonzero(~direct.all(axis=0))
        legs, rest = self._first_legs(starts[rows]), self._to_goals(goals[cols])
        out = np.where(direct, straight, np.inf)
        via = np.min(legs[:, None, :] + rest[None], axis=2)
        out[np.ix_(rows, cols)] = np.where(
            direct[np.ix_(rows, cols)], straight[np.ix_(rows, cols)], via
        )
        return out

    def routes(self, starts: np.ndarray, goals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For each pair ``starts[i] → goals[i]``: the next waypoint (S, 2) and the route
        length left after it (S,). A goal in sight is its own waypoint with nothing left; a
        goal without any route (walled in) is also headed for in a straight line."""
        starts = np.asarray(starts, dtype=float).reshape(-1, 2)
        goals = np.asarray(goals, dtype=float).reshape(-1, 2)
        waypoints, remaining = goals.copy(), np.zeros(len(goals))
        if not len(self.corners) or not len(goals):
            return waypoints, remaining
        blocked = np.flatnonzero(~self._direct_pairs(starts, goals))
        if not len(blocked):
            return waypoints, remaining
        rest = self._to_goals(goals[blocked])  # (B, C): corner to the pair's goal
        total = self._first_legs(starts[blocked]) + rest
        best = np.argmin(total, axis=1)
        rows = np.arange(len(blocked))
        found = np.isfinite(total[rows, best])
        waypoints[blocked[found]] = self.corners[best[found]]
        remaining[blocked[found]] = rest[rows, best][found]
        return waypoints, remaining


class RouteMaps:
    """The last few :class:`RouteMap` built, by their discs: known zones change rarely, so
    most steps reuse the visibility graph of the step before."""

    def __init__(self, lower: np.ndarray, upper: np.ndarray, size: int = 8):
        self.lower, self.upper, self.size = lower, upper, size
        self._maps: OrderedDict[bytes, RouteMap] = OrderedDict()

    def get(self, discs: np.ndarray) -> RouteMap:
        """The route map of these discs ``(k, 3)``, reused when the same discs came recently."""
        key = np.ascontiguousarray(discs, dtype=float).tobytes()
        found = self._maps.get(key)
        if found is None:
            found = self._maps[key] = RouteMap(discs, self.lower, self.upper)
            while len(self._maps) > self.size:
                self._maps.popitem(last=False)
        self._maps.move_to_end(key)
        return found
