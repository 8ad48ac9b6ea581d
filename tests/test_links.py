"""Jamming rule, link graph and leagues on hand-made geometries (docs/model.md §1, paper eq. 4)."""

from __future__ import annotations

import numpy as np
import pytest

from resilient_tracking.models.graph import components
from resilient_tracking.world.links import jammed_by, link_matrix


def pts(*xy: tuple[float, float]) -> np.ndarray:
    return np.array(xy, dtype=float).reshape(-1, 2)


# ---------------------------------------------------------------------------- jammed_by


def test_jammed_because_i_is_close_to_the_jammer() -> None:
    # ‖x0 − C‖ = 0.5 ≤ 0.5 · ‖x0 − x1‖ = 2; ‖x1 − C‖ = 4.5 > 2.
    positions = pts((0.5, 0.0), (4.5, 0.0))
    jam = jammed_by(positions, pts((0.0, 0.0)), np.array([0.5]))
    assert jam.shape == (1, 2, 2)
    assert jam[0, 0, 1] and jam[0, 1, 0]


def test_jammed_because_j_is_close_to_the_jammer() -> None:
    # Same geometry mirrored: now only the second endpoint is near the jammer.
    positions = pts((-4.0, 0.0), (0.0, 0.5))
    jam = jammed_by(positions, pts((0.0, 0.0)), np.array([0.5]))
    assert jam[0, 0, 1] and jam[0, 1, 0]


def test_not_jammed_when_both_endpoints_far() -> None:
    # Both 5 m from the jammer, 1 m apart: 5 > 0.5 · 1.
    positions = pts((5.0, 0.0), (5.0, 1.0))
    jam = jammed_by(positions, pts((0.0, 0.0)), np.array([0.5]))
    assert not jam.any()


def test_large_delta2_jams_far_links() -> None:
    # Same geometry as above, but δ2 = 5: 5 ≤ 5 · 1 → jammed.
    positions = pts((5.0, 0.0), (5.0, 1.0))
    jam = jammed_by(positions, pts((0.0, 0.0)), np.array([5.0]))
    assert jam[0, 0, 1] and jam[0, 1, 0]


@pytest.mark.parametrize(("delta2", "expected"), [(0.5, True), (0.49, False), (0.51, True)])
def test_boundary_equality_is_jammed(delta2: float, expected: bool) -> None:
    # ‖x0 − C‖ = 1, ‖x0 − x1‖ = 2: equality at δ2 = 0.5 (exact in binary floating point).
    positions = pts((1.0, 0.0), (3.0, 0.0))
    jam = jammed_by(positions, pts((0.0, 0.0)), np.array([delta2]))
    assert bool(jam[0, 0, 1]) is expected
    assert bool(jam[0, 1, 0]) is expected


def test_several_jammers_each_judged_with_its_own_strength() -> None:
    positions = pts((0.0, 0.0), (4.0, 0.0), (10.0, 0.0), (10.0, 4.0))
    centers = pts((0.5, 0.0), (10.0, 3.5))
    delta2 = np.array([0.2, 0.2])
    jam = jammed_by(positions, centers, delta2)
    assert jam.shape == (2, 4, 4)
    # Jammer 0 near robot 0: 0.5 ≤ 0.2 · ‖x0 − xj‖ for every j (distances 4, 10, 10.77).
    assert jam[0, 0, 1:].all() and jam[0, 1:, 0].all()
    # ...but not link 2–3 (robots 2, 3 are 9.5 and ~10.1 from jammer 0, 4 m apart).
    assert not jam[0, 2, 3]
    # Jammer 1 near robot 3 (0.5 away): jams 3–2 (0.5 ≤ 0.8), 3–1, 3–0.
    assert jam[1, 3, :3].all() and jam[1, :3, 3].all()
    # Jammer 1 does not jam 0–1 (both ≥ 6.9 m from it, 4 m apart: 0.2 · 4 = 0.8).
    assert not jam[1, 0, 1]
    # Per-jammer strength matters: weaken jammer 0 so that only the 10 m links stay jammed.
    jam_weak = jammed_by(positions, centers, np.array([0.1, 0.2]))
    assert not jam_weak[0, 0, 1]  # 0.5 > 0.1 · 4
    assert jam_weak[0, 0, 2]  # 0.5 ≤ 0.1 · 10
    assert (jam_weak[1] == jam[1]).all()


def test_no_jammers_gives_empty_stack() -> None:
    jam = jammed_by(pts((0.0, 0.0), (1.0, 0.0)), np.zeros((0, 2)), np.zeros(0))
    assert jam.shape == (0, 2, 2)


def test_diagonal_never_jammed_and_matrix_symmetric() -> None:
    rng = np.random.default_rng(7)
    positions = rng.uniform(-3, 3, (12, 2))
    centers = rng.uniform(-3, 3, (3, 2))
    # Include a robot sitting exactly on a jammer: distance 0 ≤ δ2 · 0 would jam i–i.
    positions[0] = centers[0]
    jam = jammed_by(positions, centers, np.array([0.3, 1.0, 2.0]))
    idx = np.arange(len(positions))
    assert not jam[:, idx, idx].any()
    assert (jam == jam.transpose(0, 2, 1)).all()
    # Robot 0 on jammer 0 has every link jammed by it.
    assert jam[0, 0, 1:].all()


def test_matches_brute_force_rule() -> None:
    rng = np.random.default_rng(11)
    positions = rng.uniform(-3, 3, (9, 2))
    centers = rng.uniform(-3, 3, (2, 2))
    delta2 = np.array([0.4, 0.9])
    jam = jammed_by(positions, centers, delta2)
    for k in range(2):
        for i in range(9):
            for j in range(9):
                pair = np.linalg.norm(positions[i] - positions[j])
                expected = i != j and (
                    np.linalg.norm(positions[i] - centers[k]) <= delta2[k] * pair
                    or np.linalg.norm(positions[j] - centers[k]) <= delta2[k] * pair
                )
                assert bool(jam[k, i, j]) == expected, (k, i, j)


# ---------------------------------------------------------------------------- link_matrix


def test_link_matrix_all_linked_without_failures() -> None:
    positions = pts((0.0, 0.0), (1.0, 0.0), (0.0, 1.0))
    links = link_matrix(positions, np.ones(3, bool), np.zeros((0, 3, 3), bool), None)
    assert (links == ~np.eye(3, dtype=bool)).all()


def test_failed_radio_removes_all_links_of_that_robot() -> None:
    positions = pts((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0))
    comm_ok = np.array([True, False, True, True])
    links = link_matrix(positions, comm_ok, np.zeros((0, 4, 4), bool), None)
    assert not links[1].any() and not links[:, 1].any()
    others = [0, 2, 3]
    sub = links[np.ix_(others, others)]
    assert (sub == ~np.eye(3, dtype=bool)).all()


def test_jammed_links_are_removed() -> None:
    positions = pts((0.5, 0.0), (4.5, 0.0), (4.5, 1.0))
    jam = jammed_by(positions, pts((0.0, 0.0)), np.array([0.5]))
    links = link_matrix(positions, np.ones(3, bool), jam, None)
    assert not links[0].any()
    assert links[1, 2] and links[2, 1]


def test_comm_range_cuts_long_links_and_keeps_boundary() -> None:
    positions = pts((0.0, 0.0), (2.0, 0.0), (5.0, 0.0))
    links = link_matrix(positions, np.ones(3, bool), np.zeros((0, 3, 3), bool), 3.0)
    assert links[0, 1] and links[1, 2]  # 2 m and exactly 3 m (boundary kept)
    assert not links[0, 2]  # 5 m
    assert (links == links.T).all()
    assert not np.diag(links).any()


# ---------------------------------------------------------------------------- components


def adjacency(n: int, edges: list[tuple[int, int]]) -> np.ndarray:
    a = np.zeros((n, n), dtype=bool)
    for i, j in edges:
        a[i, j] = a[j, i] = True
    return a


@pytest.mark.parametrize(
    ("n", "edges", "expected"),
    [
        (4, [(0, 1), (1, 2), (2, 3)], [[0, 1, 2, 3]]),  # chain
        (4, [(3, 2), (2, 0), (0, 1)], [[0, 1, 2, 3]]),  # chain in scrambled order
        (5, [(0, 3), (1, 2)], [[0, 3], [1, 2], [4]]),  # two islands and an isolated node
        (5, [(4, 1), (3, 2)], [[0], [1, 4], [2, 3]]),  # leagues sorted by smallest member
        (3, [], [[0], [1], [2]]),  # all isolated
        (1, [], [[0]]),
        (0, [], []),  # empty team
    ],
)
def test_components(n: int, edges: list[tuple[int, int]], expected: list[list[int]]) -> None:
    assert components(adjacency(n, edges)) == expected


def test_components_match_scipy_on_random_graphs() -> None:
    """Sparse to complete graphs (the complete ones take the one-league shortcut), links in
    one direction only, any diagonal: the same leagues as SciPy's connected components."""
    from scipy.sparse.csgraph import connected_components

    rng = np.random.default_rng(0)
    complete = 0
    for _ in range(500):
        n = int(rng.integers(1, 9))
        a = rng.random((n, n)) < rng.choice([0.1, 0.5, 0.9, 1.0])
        undirected = a | a.T
        count, labels = connected_components(undirected, directed=False)
        expected = sorted(np.flatnonzero(labels == c).tolist() for c in range(count))
        assert components(a) == expected
        complete += bool((undirected | np.eye(n, dtype=bool)).all())
    assert complete > 50  # the shortcut was exercised


def test_components_of_link_matrix_with_failed_radio() -> None:
    positions = pts((0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (10.0, 0.0))
    comm_ok = np.array([True, False, True, True])
    links = link_matrix(positions, comm_ok, np.zeros((0, 4, 4), bool), 1.5)
    # 0–1 and 1–2 lost with the radio; 0–2 is 2 m > 1.5; 3 too far from everyone.
    assert components(links) == [[0], [1], [2], [3]]
    links = link_matrix(positions, np.ones(4, bool), np.zeros((0, 4, 4), bool), 1.5)
    assert components(links) == [[0, 1, 2], [3]]
