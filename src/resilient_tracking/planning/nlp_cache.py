"""The process-wide cache of symbolic league problems, and a count of the solvers built.

Symbolic problems (with their compile jobs) are shared process-wide: building them is the
expensive, stateless part. Solvers are not shared: qpOASES keeps state from one solve to the
next, so a solver's results depend on its history, which must be the episode's own. The
least recently used problems beyond ``NLP_BUDGET`` instructions are forgotten: about 40 MB
per million, so ≈ 650 MB, enough for the 14 symbolic problems (10.7 million) a 20×20 team
meets in 300 steps of the soak; a budget below a mission's working set makes the LRU cache
forget each structure before it comes back (docs/performance.md).
"""

from __future__ import annotations

import logging
import threading

from resilient_tracking.planning.cache import LruCache
from resilient_tracking.planning.layout import Slots, Structure
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.planning.solver_options import SQP_MARGIN

log = logging.getLogger(__name__)

NLP_BUDGET = 16_000_000
#: guards the cache's bookkeeping, never a build (a planner may build in a worker thread)
_LOCK = threading.Lock()
_NLPS: LruCache[tuple[Structure, float, Slots | None], LeagueNLP] = LruCache(
    NLP_BUDGET, weigh=lambda nlp: nlp.n_instructions
)

#: solvers created so far in this process (each holds native memory: see :func:`solver_builds`)
_BUILDS = {"solvers": 0}


def nlp_cache() -> LruCache[tuple[Structure, float, Slots | None], LeagueNLP]:
    """The process-wide cache of symbolic problems (its size, builds and evictions)."""
    return _NLPS


def solver_builds() -> int:
    """How many solvers (SQP or IPOPT, per problem) were created so far in this process."""
    return _BUILDS["solvers"]


def count_solver_build() -> None:
    """Count one more solver created (see :func:`solver_builds`)."""
    _BUILDS["solvers"] += 1


def shared_nlp(
    structure: Structure, margin: float = SQP_MARGIN, slots: Slots | None = None
) -> LeagueNLP:
    """The process-wide :class:`LeagueNLP` of ``structure`` (built on first use)."""

    key = (structure, margin, slots)
    with _LOCK:
        if key in _NLPS:
            return _NLPS.get(key, lambda: LeagueNLP(structure, margin, slots))
    log.debug("building league problem %s (slots %s)", structure, slots)
    built = LeagueNLP(structure, margin, slots)  # two threads may both build it: wasted, not wrong
    with _LOCK:
        return _NLPS.get(key, lambda: built)


def wait_for_compilers() -> None:
    """Block until every compile job started in this process is done (for warm-ups)."""
    with _LOCK:
        nlps = _NLPS.values()
    for nlp in nlps:
        for job in list(nlp.jobs.values()):
            if job is not None:
                job.wait()
