"""Ports whose set-up a HAT took only in part: their `list` block is not compared until they set up again.

A HAT keeps each port's messages from its device in a 4-slot queue that the main loop empties; a
message completed while the queue is full is dropped, and the interrupt prints ``MQ overrun!``
(without a port: docs/FIRMWARE-BEHAVIOUR.md#fb-active, item 6). During a set-up (2400 baud on the
firmware in the loop) a main-loop pass may be long: a frame to a device waits for the previous one
to finish (#fb-framing), so a step that sends a setting-up device several frames (`write1`,
`select`...) keeps the loop in one pass while they cross the wire, ~4 ms a byte (a sil finding:
`deltat=0000012D`, 301 ms, with ``MQ overrun!`` lines). The messages dropped then are missing from
what that HAT knows of the device (a mode without its name, format or ranges in `list`) until the
device sets up again. Which ones are dropped depends on each side's timing (the set-up baud itself
is a model difference on purpose: docs/EMULATOR-MODELS.md), so the differential oracle does not
compare the `list` block of such a port from the overrun to the port's next ``connecting`` line
(from there :mod:`.reconnecting` covers the new set-up).

The loss outlives a run on a target kept open from run to run (its next runs list the same damaged
block), so it is kept per target (:data:`for_target`, fuzz/oracles/differential_memory.py), for as long as
that target
object lives.
"""
from __future__ import annotations

from typing import FrozenSet, Iterable, Set

from ...harness.events import Event
from .differential_memory import PerTarget

__all__ = ["SetupLoss", "for_target", "SETUP_ENDS"]

# A port's set-up ends with one of these lines (established, given up, or a passive device after all).
SETUP_ENDS = frozenset({"established", "connected_passive", "timeout", "disconnected", "checksum_error",
                        "framing_error", "too_many_errors"})


class SetupLoss:
    """One HAT: the ports setting up now, and those whose set-up lost messages to a full queue."""

    def __init__(self) -> None:
        self.setting_up: Set[int] = set()
        self.lost: Set[int] = set()

    def feed(self, events: Iterable[Event]) -> None:
        """The HAT's asynchronous events, in the order it printed them."""
        for ev in events:
            if ev.kind == "mq_overrun":
                # The line names no port: every port in a set-up may have lost the message.
                self.lost |= self.setting_up
            elif ev.port is None:
                continue
            elif ev.kind == "connecting":
                self.setting_up.add(ev.port)
                self.lost.discard(ev.port)      # a new set-up: the HAT forgets what it had
            elif ev.kind in SETUP_ENDS:
                self.setting_up.discard(ev.port)

    def ports(self) -> FrozenSet[int]:
        return frozenset(self.lost)


# (kept per target object: fuzz/oracles/differential_memory.py)
for_target: PerTarget[SetupLoss] = PerTarget(SetupLoss)
