"""The start-up lines after a reset (docs/FIRMWARE-BEHAVIOUR.md#fb-startup), and the bytes a reset tore.

The start-up begins with CRLF (an empty line). A HAT reset while it was sending a line (a ``deltat=``
line, a report) has put that line's first bytes on the wire already; the start-up's CRLF then ends
them, so the empty line arrives as ``deltat=00000``. Those bytes were sent before the reset: they are
not start-up output and break no clause. What can stand there is a line cut short (no line the HAT
prints whole; also a stray byte a resetting UART may send) or a line the HAT prints on its own (a
report cut after a digit still reads as one). Anything else there, a reply or a banner line, is
judged as the start-up's first line, and fails.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Sequence

from ...harness.events import UNASKED_KINDS, classify

__all__ = ["START_UP", "StartUp", "start_up_after_reset"]

# FIRMWARE-BEHAVIOUR#fb-startup: the start-up lines, in this order, every one exactly.
START_UP = ["", "Type help <RETURN> for help", "Initialising ports", "Resetting drivers: 0123",
            "Reading driver dumps: before port_initdriver(): 0123",
            "Reading driver dumps: after port_initdriver(): 0123", "Done initialising ports"]

_TORN_KINDS = UNASKED_KINDS | {"unknown"}


@dataclass
class StartUp:
    """``lines``: the start-up as received, from its empty line on (empty if no ``Type help`` line
    came); ``leftover``: the bytes of a line the reset cut, glued before its empty line ("" if none)."""

    lines: List[str]
    leftover: str = ""


def start_up_after_reset(texts: Sequence[str]) -> StartUp:
    """The last start-up in ``texts`` (the lines received since just before the reset)."""
    hint = max((i for i, t in enumerate(texts) if t == START_UP[1]), default=-1)
    if hint < 1:
        return StartUp([])          # no `Type help` line, or nothing before it: no empty line
    first = texts[hint - 1]
    rest = list(texts[hint:hint + len(START_UP) - 1])
    if first != "" and classify(first).kind in _TORN_KINDS:
        return StartUp([""] + rest, leftover=first)
    return StartUp([first] + rest)
