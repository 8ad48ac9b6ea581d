"""The package's version, read from its installed distribution's metadata (``0.0.0`` in a
source tree that was never installed); the top level re-exports it as
``resilient_tracking.__version__``."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("resilient-tracking")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0"
