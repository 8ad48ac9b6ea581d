"""Zone knowledge: what a robot believes about danger zones (docs/model.md §3).

A zone estimate carries its kind, center mean and covariance, size (radius ``r`` for sensing,
jamming strength ``δ2`` for comm), source and the step it was learned. Within a league the
knowledge bases are merged every step: union by zone identity, and estimates without an
identity (inferred from observation) merged with a known one of the same kind nearby. A
provisional guess (``silence``: where a teammate fell silent) gives way to a better estimate,
and a zone of a hazard map (``broadcast`` before the first tick) to the clue of its attack.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from resilient_tracking.observation import ZoneClue

Source = Literal["attack", "broadcast", "circle", "silence", "degradation"]

#: Mahalanobis distance under which an unidentified estimate is the same zone as another.
SAME_ZONE_MAHALANOBIS = 3.0


@dataclass(frozen=True)
class ZoneEstimate:
    """A belief about one danger zone."""

    key: str
    kind: Literal["sensing", "comm"]
    mean: np.ndarray
    cov: np.ndarray
    size: float
    persistence: str
    source: Source
    learned_step: int
    #: the zone's id when learned from an attack clue; None when inferred
    zone_id: int | None = None
    #: extra stand-off (m) the planner keeps, e.g. the radius of an observed evasion circle
    clearance: float = 0.0

    @classmethod
    def from_clue(cls, clue: ZoneClue, step: int, source: Source = "attack") -> ZoneEstimate:
        """The estimate an attack clue gives: the zone's prior mean and covariance, its size and
        persistence, learned at ``step`` (``source``: how it came, an attack by default)."""
        return cls(
            key=f"zone{clue.zone_id}",
            kind=clue.kind,
            mean=np.asarray(clue.mu, dtype=float),
            cov=np.asarray(clue.sigma, dtype=float),
            size=float(clue.size),
            persistence=clue.persistence,
            source=source,
            learned_step=step,
            zone_id=clue.zone_id,
        )

    @classmethod
    def all_from_clue(
        cls, clue: ZoneClue, step: int, source: Source = "attack"
    ) -> list[ZoneEstimate]:
        """Every estimate a clue gives: :meth:`from_clue`'s one; for a zone of several kinds
        (``modes``), one per kind, keyed ``zone<id>-<kind>``, so each kind's constraint applies
        (paper eq. 7c for sensing, 7d for comm)."""
        if not clue.modes:
            return [cls.from_clue(clue, step, source)]
        return [
            replace(
                cls.from_clue(clue, step, source),
                key=f"zone{clue.zone_id}-{kind}",
                kind=kind,
                size=float(size),
            )
            for kind, size in clue.modes
        ]

    def mahalanobis(self, other: ZoneEstimate) -> float:
        """Mahalanobis distance between the two means under the summed covariances, ``√(dᵀ (Σ₁ +
        Σ₂)⁻¹ d)``."""
        d = self.mean - other.mean
        return float(np.sqrt(d @ np.linalg.solve(self.cov + other.cov, d)))


class KnowledgeBase:
    """One robot's (or one league's) zone estimates, keyed by identity."""

    def __init__(self, zones: dict[str, ZoneEstimate] | None = None):
        self.zones: dict[str, ZoneEstimate] = dict(zones or {})

    def __len__(self) -> int:
        return len(self.zones)

    def __contains__(self, key: str) -> bool:
        return key in self.zones

    def copy(self) -> KnowledgeBase:
        """A new knowledge base holding the same estimates (the estimates are immutable and
        shared)."""
        return KnowledgeBase(self.zones)

    def of_kind(self, kind: str) -> list[ZoneEstimate]:
        """Estimates of one kind, in a stable order (by key)."""
        return [z for k, z in sorted(self.zones.items()) if z.kind == kind]

    def learn(self, estimate: ZoneEstimate) -> bool:
        """Add an estimate; returns whether anything new was learned. An attack clue replaces
        the hazard map's estimate of the same zone: the robot now knows that zone struck it
        (the zone a robot whose radio it destroyed circles, Alg. 4)."""
        held = self.zones.get(estimate.key)
        if held is not None and not (held.source == "broadcast" and estimate.source == "attack"):
            return False
        if estimate.zone_id is None:
            for key, known in list(self.zones.items()):
                if (
                    known.kind == estimate.kind
                    and known.mahalanobis(estimate) <= SAME_ZONE_MAHALANOBIS
                ):
                    if known.source != "silence" or estimate.source == "silence":
                        return False
                    del self.zones[key]  # a fitted circle replaces the provisional guess
        self.zones[estimate.key] = estimate
        return True

    @staticmethod
    def union(bases: list[KnowledgeBase]) -> KnowledgeBase:
        """League merge: identified estimates first (oldest wins), then inferred ones."""
        merged = KnowledgeBase()
        entries = [z for kb in bases for z in kb.zones.values()]
        entries.sort(key=lambda z: (z.zone_id is None, z.learned_step, z.key))
        for z in entries:
            merged.learn(z)
        return merged
