"""Failure-aware multi-robot target tracking (Li, Liu, Wu, Zhou).

Layout: ``world`` holds truth, ``belief`` what the robots know, ``planning`` and ``policies``
decide from belief only, ``sim`` runs episodes and records them, ``viz`` plots saved data.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("resilient-tracking")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0"

__all__ = ["__version__"]
