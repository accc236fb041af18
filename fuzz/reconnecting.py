"""Ports a side is connecting again: their `list` block is not compared while that lasts.

A HAT drops a device that stops sending in its data phase and sets it up again
(docs/FIRMWARE-BEHAVIOUR.md#fb-active): ``P0: timeout during data phase: disconnecting``,
``P0: disconnected``, ``P0: connecting to active device``, then, once the device's set-up has
crossed its wire, ``P0: established ...``. How long that set-up takes is a model difference on
purpose (about 2 s on the firmware in the loop, whose devices send it at 2400 baud; 0.8 s on the
emulator: docs/EMULATOR-MODELS.md), and in a paired run the two HAT clocks run apart (only a side
with a TX ring pauses before a fence), so one side may list a port as `no device detected` while
the other lists it connected, or has not even dropped it yet (a sil finding, `--seed 11` against
``inprocess``). Timing, not behaviour: the differential oracle leaves out the `list` block of such
a port until the side has established it again, for at most :data:`WINDOW_MS` of that side's HAT
time after its last set-up line (a device that never comes back is compared again after that).
"""
from __future__ import annotations

from typing import Dict, FrozenSet, List

from ..harness.events import Event

__all__ = ["Reconnecting", "WINDOW_MS", "STARTS", "ENDS"]

WINDOW_MS = 3000.0      # a firmware set-up (~2 s at 2400 baud) after the ~0.2 s before it starts
STARTS = frozenset({"timeout", "disconnected", "connecting"})
ENDS = frozenset({"established", "connected_passive"})


class Reconnecting:
    """Per side: the ports whose last connection line began a set-up, and when (HAT ms)."""

    def __init__(self, sides: int):
        self._since: List[Dict[int, float]] = [{} for _ in range(sides)]

    def feed(self, side: int, events: List[Event], now: float) -> None:
        """A side's asynchronous events, in order, as of ``now`` (its HAT ms)."""
        since = self._since[side]
        for ev in events:
            if ev.port is None:
                continue
            if ev.kind in STARTS:
                since[ev.port] = now
            elif ev.kind in ENDS:
                since.pop(ev.port, None)

    def ports(self, nows: List[float]) -> FrozenSet[int]:
        """The ports any side is setting up again at its ``now``."""
        out = set()
        for since, now in zip(self._since, nows):
            for port, t in list(since.items()):
                if now - t > WINDOW_MS:
                    del since[port]
                else:
                    out.add(port)
        return frozenset(out)
