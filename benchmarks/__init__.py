"""Benchmarks of the planner, episodes and sweeps; run ``python -m benchmarks.all``."""
