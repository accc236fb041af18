"""A hung firmware (fault injection): ``@hang`` on the control channel, or ``--hang-after N``.

A real HAT's firmware can stop: a hard fault, a loop that never returns. Then time passes, the
UART keeps receiving until the firmware's receive ring is full (the rest is dropped), and nothing
more is printed, not even what was queued. Only a reset (the RESET line, ``@reset``) brings it
back. Hosts and the conformance run use this to show what they do with a dead HAT.
"""
from __future__ import annotations

from typing import Any, Optional

__all__ = ["Hung", "HangTrigger"]


class Hung:
    """The machine while the firmware is hung: it neither reads its ring nor writes."""

    def __init__(self, uart: Any, now: int):
        self.uart = uart
        self.now = now
        uart.tx.clear()          # what the firmware had queued never leaves either

    def poll(self) -> None:
        """The firmware would read its ring here; it does not."""

    def tick(self) -> None:
        self.now += 1
        self.uart.tick()         # the UART hardware still moves bytes into the (full) ring


class HangTrigger:
    """``--hang-after N``: the firmware hangs once, right after the host's Nth line (CR)."""

    def __init__(self, lines: Optional[int]):
        if lines is not None and lines < 1:
            raise ValueError(f"hang after must be at least 1 line, got {lines}")
        self.left = lines        # lines still to come before the hang; None: never (or done)

    def split(self, data: bytes) -> Optional[int]:
        """Where ``data`` ends the Nth line (the index after its CR), or None if it does not."""
        if self.left is None:
            return None
        count = data.count(b"\r")
        if count < self.left:
            self.left -= count
            return None
        at = -1
        for _ in range(self.left):
            at = data.index(b"\r", at + 1)
        self.left = None
        return at + 1
