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
That time is the HAT's own clock (``TargetExchange.target_now``), which goes on from run to run on a
target kept open, so a set-up begun in one run is still left out in the next.
"""
from __future__ import annotations

from typing import Dict, FrozenSet, List

from ...harness.events import Event
from .differential_memory import PerTarget

__all__ = ["Reconnecting", "for_target", "WINDOW_MS", "STARTS", "ENDS"]

WINDOW_MS = 3000.0      # a firmware set-up (~2 s at 2400 baud) after the ~0.2 s before it starts
STARTS = frozenset({"timeout", "disconnected", "connecting"})
ENDS = frozenset({"established", "connected_passive"})


class Reconnecting:
    """One HAT: the ports whose last connection line began a set-up, and when (that HAT's ms)."""

    def __init__(self) -> None:
        self._since: Dict[int, float] = {}

    def feed(self, events: List[Event], now: float) -> None:
        """The HAT's asynchronous events, in order, as of ``now`` (its HAT ms)."""
        for ev in events:
            if ev.port is None:
                continue
            if ev.kind in STARTS:
                self._since[ev.port] = now
            elif ev.kind in ENDS:
                self._since.pop(ev.port, None)

    def ports(self, now: float) -> FrozenSet[int]:
        """The ports the HAT is setting up again at its ``now``."""
        for port, t in list(self._since.items()):
            if now - t > WINDOW_MS:
                del self._since[port]
        return frozenset(self._since)


# A set-up outlives the run whose step began it on a target kept open from run to run (sil finding,
# `--against emulator --seed 22 --jobs 2`, 10 min: the firmware dropped the motor in a run's last steps
# and the next run's first `list` came 0.9 s into its set-up), so it is kept per target object.
for_target: PerTarget[Reconnecting] = PerTarget(Reconnecting)
