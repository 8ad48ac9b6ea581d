"""Assembling the league NLP's Hessian of the Lagrangian from 2×2 velocity blocks, and the
SQP's convexification of its diagonal blocks (docs/model.md §5)."""

from __future__ import annotations

from typing import Any

import casadi as ca


def sym2(e: Any) -> Any:
    """A symmetric 2×2 SX from ``[xx, xy, yy]``."""
    return ca.vertcat(ca.horzcat(e[0], e[1]), ca.horzcat(e[1], e[2]))


def psd_clip(block: Any, margin: float) -> Any:
    """A symmetric 2×2 SX ``block`` with its eigenvalues ``λ`` replaced by ``h(λ) = max(λ,
    margin)``, in closed form: ``h(λ₋) I + (h(λ₊) − h(λ₋)) / (λ₊ − λ₋) · (B − λ₋ I)``."""
    p, q, r = block[0, 0], block[0, 1], block[1, 1]
    half_gap = ca.sqrt(0.25 * (p - r) ** 2 + q * q)
    mid = 0.5 * (p + r)
    lo, hi = mid - half_gap, mid + half_gap

    def h(lam: Any) -> Any:
        return ca.fmax(lam, margin)

    slope = (h(hi) - h(lo)) / ca.fmax(2 * half_gap, 1e-300)
    return h(lo) * ca.SX.eye(2) + slope * (block - lo * ca.SX.eye(2))


def assemble(
    blocks: dict[tuple[int, int], Any], n_robots: int, n_vars: int, slack: float
) -> tuple[Any, Any]:
    """(full symmetric, upper triangle) of the Hessian from its velocity blocks ``(i, q)``,
    ``q ≥ i``; the slack variables (after the ``2 n_robots`` velocities) get ``slack`` on the
    diagonal."""
    rows, cols, vals = [], [], []
    rows_t, cols_t, vals_t = [], [], []
    for (i, q), blk in blocks.items():
        for a in range(2):
            for b in range(2):
                r, c = 2 * i + a, 2 * q + b
                v = blk[a, b]
                if r <= c:
                    rows_t.append(r)
                    cols_t.append(c)
                    vals_t.append(v)
                rows.append(r)
                cols.append(c)
                vals.append(v)
                if i != q:
                    rows.append(c)
                    cols.append(r)
                    vals.append(v)
    if slack:
        for k in range(2 * n_robots, n_vars):
            for lst in (rows, cols, rows_t, cols_t):
                lst.append(k)
            vals.append(ca.SX(slack))
            vals_t.append(ca.SX(slack))
    full = ca.SX.triplet(rows, cols, ca.vertcat(*vals), n_vars, n_vars)
    triu = ca.SX.triplet(rows_t, cols_t, ca.vertcat(*vals_t), n_vars, n_vars)
    return full, triu
