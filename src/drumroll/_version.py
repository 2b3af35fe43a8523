"""drumroll's version, from the installed package's metadata (a module of its own, below
everything that records it, so that none of them imports the package's top level)."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("drumroll")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
