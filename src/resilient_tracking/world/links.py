"""Communication links: the jamming rule and the link graph (docs/model.md §1, paper eq. 4)."""

from __future__ import annotations

import numpy as np


def jammed_by(positions: np.ndarray, jammer_centers: np.ndarray, delta2: np.ndarray) -> np.ndarray:
    """(K, M, M) bool: link ``i–j`` jammed by zone ``k``.

    Jammed when ``‖x_i − x_C‖ ≤ δ2 ‖x_i − x_j‖`` or the same with ``i`` and ``j`` swapped.
    """
    m = len(positions)
    if len(jammer_centers) == 0:
        return np.zeros((0, m, m), dtype=bool)
    pair = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=-1)  # (M, M)
    to_jammer = np.linalg.norm(
        positions[None, :, :] - jammer_centers[:, None, :], axis=-1
    )  # (K, M)
    one_side = to_jammer[:, :, None] <= delta2[:, None, None] * pair[None, :, :]
    jam = one_side | one_side.transpose(0, 2, 1)
    idx = np.arange(m)
    jam[:, idx, idx] = False
    return jam


def link_matrix(
    positions: np.ndarray,
    comm_ok: np.ndarray,
    jammed: np.ndarray,
    comm_range: float | None,
) -> np.ndarray:
    """(M, M) bool: linked when both radios work, no zone jams the link, and within range."""
    m = len(positions)
    links = comm_ok[:, None] & comm_ok[None, :]
    if jammed.size:
        links &= ~jammed.any(axis=0)
    if comm_range is not None:
        pair = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=-1)
        links &= pair <= comm_range
    links.flat[:: m + 1] = False  # the diagonal (faster than fancy indexing)
    return links
