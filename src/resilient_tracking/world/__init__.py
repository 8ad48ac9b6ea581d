"""Ground truth, owned by the simulator only: robots, targets, danger zones, failures, links.

Nothing in ``belief``, ``planning`` or ``policies`` may import from here (a test enforces it).
"""

from resilient_tracking.world.world import World

__all__ = ["World"]
