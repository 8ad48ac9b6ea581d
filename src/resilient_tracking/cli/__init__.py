"""``rtrack``: the command line. The only part of the package that talks to the person."""

from resilient_tracking.cli.entry import main

__all__ = ["main"]
