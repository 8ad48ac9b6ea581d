"""A least-recently-used cache with a size budget, for the planner's per-structure problems.

Every league structure (robots, targets, known zones) gets its own symbolic problem and solver,
and a long mission meets new structures as zones are learned and leagues split: kept forever,
they grow memory without bound (docs/reliability.md §4). :class:`LruCache` keeps the most
recently used entries whose summed weight fits a budget and forgets the rest; a forgotten
structure is simply rebuilt if it comes back.
"""

from __future__ import annotations

import logging
from collections import OrderedDict
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

log = logging.getLogger(__name__)

K = TypeVar("K")
V = TypeVar("V")


class LruCache(Generic[K, V]):
    """``get(key, build)`` returns the cached value or builds, stores and returns it.

    After each insertion the least recently used entries are evicted until the summed
    ``weigh(value)`` is at most ``budget``; the newest entry is always kept, however heavy.
    Weights are read afresh at each insertion (a value may build its parts lazily and grow).
    ``on_evict(key, value)`` is called for each evicted entry.
    """

    def __init__(
        self,
        budget: float,
        weigh: Callable[[V], float] = lambda value: 1.0,
        on_evict: Callable[[K, V], None] | None = None,
    ):
        if not budget > 0:
            raise ValueError(f"budget: expected a positive number, got {budget!r}")
        self.budget = budget
        self.weigh = weigh
        self.on_evict = on_evict
        self._entries: OrderedDict[K, V] = OrderedDict()
        #: how many entries were built and evicted so far
        self.builds = 0
        self.evictions = 0

    @property
    def total(self) -> float:
        """The summed weight of the entries now."""
        return sum(float(self.weigh(value)) for value in self._entries.values())

    def get(self, key: K, build: Callable[[], V]) -> V:
        """The value cached under ``key``, else ``build()``'s, stored as the most recently used
        entry (the least recently used are then evicted down to the budget)."""
        if key in self._entries:
            self._entries.move_to_end(key)
            return self._entries[key]
        value = self._entries[key] = build()
        self.builds += 1
        weights = {k: float(self.weigh(v)) for k, v in self._entries.items()}
        total = sum(weights.values())
        while total > self.budget and len(self._entries) > 1:
            old_key, old_value = self._entries.popitem(last=False)
            total -= weights[old_key]
            self.evictions += 1
            log.debug("evicting %s (weight %g) from the cache", old_key, weights[old_key])
            if self.on_evict is not None:
                self.on_evict(old_key, old_value)
        return value

    def __contains__(self, key: object) -> bool:
        return key in self._entries

    def __len__(self) -> int:
        return len(self._entries)

    def __iter__(self) -> Iterator[K]:
        return iter(list(self._entries))

    def values(self) -> list[V]:
        """The cached values, least recently used first."""
        return list(self._entries.values())

    def clear(self) -> None:
        """Forget every entry (without calling ``on_evict``)."""
        self._entries.clear()
