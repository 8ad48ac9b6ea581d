"""A greedy nearest-target policy for resilient_tracking (an example plug-in)."""

from greedy_tracker.policy import GreedyParams, GreedyPolicy

__all__ = ["GreedyParams", "GreedyPolicy"]
