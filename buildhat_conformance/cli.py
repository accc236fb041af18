"""The ``buildhat-conformance`` entry point. The dispatcher is harness/cli_dispatch.py: inside
the package every import is relative, and the folders install under this package's name, so
it is reached here by that name."""
from __future__ import annotations

import importlib
import sys
from typing import Optional, Sequence

__all__ = ["main"]


def main(argv: Optional[Sequence[str]] = None) -> int:
    return importlib.import_module("buildhat_conformance.harness.cli_dispatch").main(argv)


if __name__ == "__main__":
    sys.exit(main())
