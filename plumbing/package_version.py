"""The package's version, read from its installed metadata (one source: pyproject.toml)."""
from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("buildhat-conformance")
except PackageNotFoundError:  # a plain checkout that was never installed
    __version__ = "0+unknown"
