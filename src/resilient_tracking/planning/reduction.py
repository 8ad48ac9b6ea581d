"""The SQP's reduced league problem: only the zones and teammates that can bind this step.

Within one step a robot moves at most ``u_max dt``, so most rows can never bind: zones far
from a robot, and for the jamming rows every teammate but the farthest few. qpOASES pays for
every slack at its bound and every row in each QP (it rebuilds its factorisation from the
previous working set for every new Hessian and Jacobian), so for large leagues the SQP solves
a problem with a fixed number of *slots* per robot (:class:`~.layout.Slots`) whose zone and
teammate are parameters, filled each step with what can bind; what is left out provably
holds (:func:`reduce`). Same solutions, same structure every step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resilient_tracking.planning.layout import (
    CommRow,
    ProblemInputs,
    SensingRow,
    Slots,
    Structure,
    VariableLayout,
    Weight,
    ZoneNeeds,
)
from resilient_tracking.planning.margins import keep_out_lower_bound, pair_distance_upper_bound
from resilient_tracking.planning.solver_options import SLOTS


def reduced_slots(structure: Structure, slots: Slots | None = SLOTS) -> Slots | None:
    """``slots`` capped at the structure's sizes; None when that reduces nothing."""
    if slots is None:
        return None
    n, nl, nk = structure.n_robots, structure.n_sensing_zones, structure.n_comm_zones
    comm = min(slots.comm, nk)
    capped = Slots(min(slots.sensing, nl), comm, min(slots.mates, n - 1) if comm else 0)
    if capped.sensing == nl and capped.comm == nk and (not nk or capped.mates == n - 1):
        return None
    return capped


@dataclass
class Reduction:
    """One step's reduced problem (:func:`reduce`)."""

    #: the sizes of the reduced problem it fills
    slots: Slots
    #: the selection parameters (ssel, csel, msel), flattened column by column
    selection: np.ndarray
    #: each reduced row's row in the full problem, and whether the row is in use
    rows: np.ndarray
    active: np.ndarray
    #: each reduced slack's variable in the full problem (−1: an unused slot)
    variables: np.ndarray
    #: velocities first, the same in both problems
    n_u: int
    #: rows of the full problem
    n_constraints: int
    #: the full problem's bound multipliers of the slacks the reduced problem drops
    dropped_lam_x: np.ndarray

    def reduce(self, full: np.ndarray) -> np.ndarray:
        """A full problem's ``x`` or ``lam_x`` for the reduced problem."""
        used = self.variables >= 0
        slack = np.where(used, full[np.maximum(self.variables, 0)], 0.0)
        return np.concatenate([full[: self.n_u], slack])

    def reduce_rows(self, full: np.ndarray) -> np.ndarray:
        """A full problem's ``lam_g`` for the reduced problem."""
        return np.where(self.active, full[self.rows], 0.0)

    def expand(self, reduced: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The reduced problem's solution as the full problem's: dropped slacks are 0 at their
        bound, whose multiplier is then their cost (``∂L/∂ν = w + lam_x = 0``); dropped rows'
        multipliers are 0."""
        used = self.variables >= 0
        solution = {"f": reduced["f"]}
        for key, full in (("x", np.zeros(len(self.dropped_lam_x))), ("lam_x", None)):
            full = self.dropped_lam_x.copy() if full is None else full
            full[: self.n_u] = reduced[key][: self.n_u]
            full[self.variables[used]] = reduced[key][self.n_u :][used]
            solution[key] = full
        lam_g = np.zeros(self.n_constraints)
        lam_g[self.rows[self.active]] = reduced["lam_g"][self.active]
        solution["lam_g"] = lam_g
        return solution


def zone_needs(q: ProblemInputs) -> ZoneNeeds | None:
    """The zone rows of ``q`` that may bind within the velocity bounds (points 1 and 2 of
    :func:`reduce`'s proof: every other row holds with a zero slack), or None when that cannot
    be told (a negative ``δ2``, ``w3`` or ``w4``, or a robot with no link kept). Inputs that
    carry their needs (:attr:`~.layout.ProblemInputs.zone_needs`) are not judged again."""
    if q.zone_needs is not None:
        return q.zone_needs
    n = len(q.positions)
    zs = q.sensing_zones.reshape(-1, SensingRow.WIDTH)
    zc = q.comm_zones.reshape(-1, CommRow.WIDTH)
    w = q.weights
    if np.any(zc[:, CommRow.DELTA2] < 0) or w[Weight.SENSING_SLACK] < 0 or w[Weight.COMM_SLACK] < 0:
        return None
    x = q.positions
    span = np.maximum(np.abs(q.u_lower), np.abs(q.u_upper))
    reach = q.dt * np.hypot(span[:, 0], span[:, 1])

    def above(value: np.ndarray) -> np.ndarray:
        return np.asarray(value > 1e-9 * (1 + np.abs(value)))

    bound_s = keep_out_lower_bound(
        x, reach, zs[:, SensingRow.GAUSSIAN], zs[:, SensingRow.R_SAFE], zs[:, SensingRow.BETA]
    )
    need_s = ~above(bound_s)
    d = np.hypot(x[:, None, 0] - x[None, :, 0], x[:, None, 1] - x[None, :, 1])
    far = d + reach[:, None] + reach[None, :]
    near = d - reach[:, None] - reach[None, :]
    np.fill_diagonal(far, -np.inf)
    np.fill_diagonal(near, -np.inf)
    if q.unlinked is not None and n > 1:
        # a link the route program leaves out of eq. 7d: its rows are ``h + ξ ≥ 0``, which
        # every kept row of the robot implies (``δ2 ≥ 0``); a robot with no link kept: full
        unlinked = np.asarray(q.unlinked) > 0.5
        np.fill_diagonal(unlinked, True)
        if unlinked.all(axis=1).any():
            return None
        far[unlinked] = -np.inf
        near[unlinked] = -np.inf
    pair_top = pair_distance_upper_bound(far.max(axis=1)) if n > 1 else np.zeros(n)
    bound_c = keep_out_lower_bound(
        x, reach, zc[:, CommRow.GAUSSIAN], zc[:, CommRow.CLEARANCE], zc[:, CommRow.BETA]
    )
    need_c = ~above(bound_c - zc[:, CommRow.DELTA2] * pair_top[:, None])
    return ZoneNeeds(need_s, need_c, near, far)


def reduce(structure: Structure, slots: Slots, q: ProblemInputs) -> Reduction | None:
    """What the reduced problem with ``slots`` keeps of this step's problem, or None when the
    full problem must be solved: a robot needing more zones or teammates than it has slots, or
    a negative ``δ2``, ``w3`` or ``w4``.

    **Why the reduced problem has the same solutions.** The velocity bounds confine robot
    ``i``'s step to a disc of radius ``r_i = dt ‖(max(|lbu_ix|, |ubu_ix|), max(|lbu_iy|,
    |ubu_iy|))‖`` around ``x_i``; every SQP iterate stays within the bounds (each QP step
    does, and the line search moves along it), and so does the solution. Over that disc
    :func:`~.margins.keep_out_lower_bound` gives a lower bound ``H`` of a keep-out margin.

    1. A sensing row ``(i, l)`` with ``H_il > tol`` holds with ``ν_il = 0`` for every
       control within the bounds. ``ν_il`` appears only there and in the objective with
       weight ``w3 ≥ 0``, so ``ν_il = 0`` at every solution (any solution with ``ν_il > 0``
       stays feasible and gets no worse with ``ν_il = 0``). Row and slack are dropped.
    2. A comm row ``(i, k, q)`` is ``h_ik(x_i⁺) − δ2 ρ(x_i⁺ − x_q⁺) + ξ_ik ≥ 0`` with
       ``ρ(v) = √(‖v‖² + ε²)`` increasing in ``‖v‖ ≤ d_iq + r_i + r_q`` (``d_iq = ‖x_i −
       x_q‖``). If ``H_ik − δ2 max_q ρ(d_iq + r_i + r_q) > tol`` every row of ``(i, k)``
       holds with ``ξ_ik = 0``: as in 1., the rows and ``ξ_ik`` are dropped.
    3. For the comm zones a robot keeps, its rows differ only in the teammate (among the
       teammates whose link the route program keeps, ``unlinked``). Let ``q*``
       maximise ``d_iq − r_i − r_q``, a lower bound of ``‖x_i⁺ − x_q⁺‖``. A teammate with
       ``d_iq + r_i + r_q < d_iq* − r_i − r_q*`` is always nearer than ``q*``, so
       ``g_iqk ≥ g_iq*k`` (``δ2 ≥ 0``) and its row holds wherever row ``q*``'s does: it is
       dropped.

    So within the bounds the reduced and the full problem have the same feasible set up
    to dropped slacks that are zero at every solution: the same solutions, with the
    dropped rows' multipliers zero. ``tol`` (1e-9 m plus a relative 1e-9) covers rounding.
    A slot left unused gets a zero selection column (its slack costs nothing and is fixed
    at 0, its row is relaxed to ``−∞``): it changes nothing.
    """
    return fill_slots(structure, slots, zone_needs(q), q.weights)


def fill_slots(
    structure: Structure, slots: Slots, needs: ZoneNeeds | None, w: np.ndarray
) -> Reduction | None:
    """:func:`reduce` from the step's :func:`zone_needs` and weights ``w``, for callers that
    try several slot sizes on one step."""
    s = structure
    n, nl, nk = s.n_robots, s.n_sensing_zones, s.n_comm_zones
    if needs is None:
        return None
    need_s, need_c, near, far = needs.sensing, needs.comm, needs.near, needs.far
    best = near.max(axis=1)
    mates = far * (1 + 1e-9) + 1e-9 >= best[:, None]
    needs_mates = np.asarray(need_c.any(axis=1))
    mates &= needs_mates[:, None]
    if (
        need_s.sum(axis=1).max(initial=0) > slots.sensing
        or need_c.sum(axis=1).max(initial=0) > slots.comm
        or mates.sum(axis=1).max(initial=0) > slots.mates
    ):
        return None
    n_s, n_c, n_m = slots.sensing, slots.comm, slots.mates
    robot = np.arange(n)[:, None]
    full_rows = nl + nk * (n - 1)  # rows per robot in the full problem
    # the zones a robot needs fill its first slots, in zone order
    ssel = np.zeros((n, n_s, nl))
    slot_s = np.cumsum(need_s, axis=1) - 1
    i_s, l_s = np.nonzero(need_s)
    ssel[i_s, slot_s[i_s, l_s], l_s] = 1.0
    csel = np.zeros((n, n_c, nk))
    slot_c = np.cumsum(need_c, axis=1) - 1
    i_c, k_c = np.nonzero(need_c)
    csel[i_c, slot_c[i_c, k_c], k_c] = 1.0
    # teammates by their guaranteed distance, farthest first (a stable slot order);
    # unused teammate slots repeat the first, their rows relaxed
    msel = np.zeros((n, n_m, max(n - 1, 0)))
    order = np.argsort(np.where(mates, -near, np.inf), axis=1, kind="stable")[:, :n_m]
    in_use = np.asarray(np.arange(n_m)[None, :] < mates.sum(axis=1)[:, None])
    team = np.where(in_use, order, order[:, :1]) if n_m else order
    team = team - (team > robot)  # teammates numbered without robot i
    if n_m:
        msel[robot, np.arange(n_m)[None, :], team] = needs_mates[:, None]
    # each reduced row's full row, and whether it is in use
    zone_s = np.einsum("isl,l->is", ssel, np.arange(nl))
    zone_c = np.einsum("ick,k->ic", csel, np.arange(nk))
    used_s, used_c = np.asarray(ssel.any(axis=2)), np.asarray(csel.any(axis=2))
    rows_s = robot * full_rows + zone_s
    rows_c = robot[:, :, None] * full_rows + nl + zone_c[:, :, None] * (n - 1)
    rows_c = rows_c + team[:, None, :]
    active_c = used_c[:, :, None] & in_use[:, None, :]
    rows = np.concatenate([rows_s, rows_c.reshape(n, -1)], axis=1).astype(np.intp)
    active = np.concatenate([used_s, active_c.reshape(n, -1)], axis=1)
    # each reduced slack's variable in the full problem (−1: unused); ν of every robot,
    # then ξ of every robot, as in the reduced problem's x
    full = VariableLayout(n, nl, nk)
    var_s = np.where(used_s, full.nu(robot, zone_s), -1)
    var_c = np.where(used_c, full.xi(robot, zone_c), -1)
    dropped_lam_x = np.zeros(s.n_vars)
    dropped_lam_x[full.nu(0, 0) : full.xi(0, 0)] = -w[Weight.SENSING_SLACK]
    dropped_lam_x[full.xi(0, 0) :] = -w[Weight.COMM_SLACK]
    return Reduction(
        slots=slots,
        selection=np.concatenate([ssel.ravel(), csel.ravel(), msel.ravel()]),
        rows=rows.ravel(),
        active=active.ravel(),
        variables=np.concatenate([var_s.ravel(), var_c.ravel()]).astype(np.intp),
        n_u=full.n_u,
        n_constraints=s.n_constraints,
        dropped_lam_x=dropped_lam_x,
    )
