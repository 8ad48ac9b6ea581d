"""Seeded solver-fault injection for reliability tests (docs/reliability.md, docs/model.md §9).

:class:`FaultInjector` is a :data:`~resilient_tracking.planning.planner.FaultHook`: the
:class:`~resilient_tracking.planning.planner.LeaguePlanner` calls it after every solver attempt
with the rung's name, the solution and the solver statistics, and uses what it returns. With
probability ``probability`` per attempt it corrupts the attempt in one of four ways:

``infeasible``
    the solver reports an infeasible problem (``success`` false);
``nan``
    the solution vector is NaN while the solver claims success;
``exception``
    the solver raises :class:`InjectedSolverFault`;
``iteration_limit``
    the solver stops at its iteration limit (``success`` false).

Draws come from a generator seeded by ``seed`` alone, so a campaign is reproducible. The injector
knows nothing of the planner's rungs beyond an optional filter ``rungs`` (``None``: every rung),
and counts what it did in :attr:`FaultInjector.counts`.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterable
from typing import Any, Literal

import numpy as np

log = logging.getLogger(__name__)

FaultKind = Literal["infeasible", "nan", "exception", "iteration_limit"]
FAULT_KINDS: tuple[FaultKind, ...] = ("infeasible", "nan", "exception", "iteration_limit")


class InjectedSolverFault(RuntimeError):
    """The exception an injected ``exception`` fault raises."""


class FaultInjector:
    """Corrupts solver attempts at random; usable as ``LeaguePlanner(fault_hook=...)``."""

    def __init__(
        self,
        probability: float = 0.3,
        kinds: Iterable[FaultKind] = FAULT_KINDS,
        rungs: Iterable[str] | None = None,
        seed: int = 0,
    ):
        if not 0.0 <= probability <= 1.0:
            raise ValueError(f"probability: must be in [0, 1] (got {probability})")
        self.kinds: tuple[FaultKind, ...] = tuple(kinds)
        unknown = sorted(set(self.kinds) - set(FAULT_KINDS))
        if not self.kinds or unknown:
            raise ValueError(f"kinds: choose from {list(FAULT_KINDS)} (got {list(self.kinds)})")
        self.probability = float(probability)
        self.rungs = None if rungs is None else frozenset(rungs)
        self.rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5F17]))
        #: attempts seen, per rung
        self.calls: Counter[str] = Counter()
        #: faults injected, per (rung, kind)
        self.counts: Counter[tuple[str, str]] = Counter()

    @property
    def injected(self) -> int:
        """Total faults injected so far."""
        return sum(self.counts.values())

    def __call__(
        self, rung: str, solution: dict[str, Any], stats: dict[str, Any]
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        self.calls[rung] += 1
        if self.rungs is not None and rung not in self.rungs:
            return solution, stats
        # one uniform and one choice per attempt, whatever happens: the sequence of draws is
        # fixed by the number of attempts alone
        hit = self.rng.random() < self.probability
        kind = self.kinds[int(self.rng.integers(len(self.kinds)))]
        if not hit:
            return solution, stats
        self.counts[(rung, kind)] += 1
        log.debug("injecting %s into the %s attempt", kind, rung)
        stats = dict(stats)
        if kind == "exception":
            raise InjectedSolverFault(f"injected solver exception ({rung} attempt)")
        if kind == "infeasible":
            stats.update(success=False, return_status="Infeasible_Problem_Detected")
        elif kind == "iteration_limit":
            stats.update(
                success=False,
                return_status="Maximum_Iterations_Exceeded",
                iter_count=max(int(stats.get("iter_count", 0)), 3000),
            )
        elif kind == "nan":
            solution = dict(solution)
            solution["x"] = np.full(np.shape(solution["x"]), np.nan)
        return solution, stats

    def summary(self) -> dict[str, int]:
        """Faults injected per kind, plus ``attempts`` seen."""
        out: dict[str, int] = {kind: 0 for kind in self.kinds}
        for (_, kind), n in self.counts.items():
            out[kind] += n
        out["attempts"] = sum(self.calls.values())
        return out
