"""The reference emulator of the Build HAT firmware (all releases R1..R7, as profiles).

``Emulator`` (emulator/api.py) is the Python API; ``buildhat-emulator`` (emulator/cli.py)
the process. The API is imported lazily so that ``import buildhat_conformance.emulator``
(e.g. by the pytest plugin) stays cheap.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:               # for static tools only: at run time __getattr__ imports it
    from .api import Emulator

__all__ = ["Emulator"]


def __getattr__(name: str) -> Any:
    if name == "Emulator":
        from .api import Emulator
        return Emulator
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
