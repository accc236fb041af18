"""What the HAT can take from a host: its receive ring against the wire and the cost of each line.

The host lint's ``overrun`` rule asks one question: would a real HAT have lost bytes of this host's
input? FIRMWARE-BEHAVIOUR.md#fb-uart, #fb-tx-ring: the command UART runs at 115200 baud (8N1, so at most
11.52 bytes per ms reach the HAT) into an RX ring of 8192 bytes, and a byte that arrives when the ring is
full is dropped. The main loop takes the ring's lines one after another, and a line costs what its commands
cost on the 133 MHz Cortex-M0+ (#fb-stall: a ``list`` of three active devices stretches its pass past 2 ms).

The model, in HAT milliseconds: line ``i`` (``b`` bytes with its CR) finishes arriving at
``a = max(now, a_prev) + b / 11.52`` (a host cannot push bytes faster than the wire, whatever our own
link allowed); the HAT finishes running it at ``f = max(a, f_prev) + cost``. The ring holds, when a line
arrives, the bytes of every line not yet finished. Above the ring size the HAT would have dropped input.

Short lines cost tens of microseconds and take longer than that on the wire, so no rate of ordinary
commands can fill the ring (python-build-hat's own stress tests send 112 and 768 lines/s); only lines that
cost more than they take to arrive (``list`` storms) can. The costs are the emulator's stall-line model
(:class:`~.pass_cost.PassCost` over the profile's ``main_loop_cost``, docs/EMULATOR-MODELS.md): the running
profile's values, the default release's when no profile is known, and a ``list`` costs what the HAT's ports
would print.
"""
from __future__ import annotations

from collections import deque
from typing import Any, Deque, List, Optional, Tuple

from ...protocol.pass_cost import PassCost
from ...protocol.profiles import get_profile

__all__ = ["IntakeModel", "WIRE_BYTES_PER_MS", "line_cost_ms"]

WIRE_BYTES_PER_MS = 115200 / 10 / 1000      # FIRMWARE-BEHAVIOUR.md#fb-uart: 115200 baud, 8N1
_PORTS = 4


#: The firmware's receive ring (docs/FIRMWARE-BEHAVIOUR.md#fb-uart); the lint's own model of it, as the
#: fuzzer has its own (the emulator's ring is one more model, not the reference).
RING_SIZE = 8192


class IntakeModel:
    """The receive ring of a HAT fed by a 115200-baud wire; :meth:`line` returns the ring's fill."""

    def __init__(self, ring: int = RING_SIZE):
        self.ring = ring
        self._arrived = 0.0           # when the wire finished carrying the last line (HAT ms)
        self._busy = 0.0              # when the HAT finishes running the last line
        self._queued: Deque[Tuple[float, int]] = deque()    # (finish time, bytes) of unfinished lines
        self._held = 0                # sum of the bytes in _queued

    def line(self, now: float, size: int, cost_ms: float) -> int:
        """One host line of ``size`` bytes (CR included) seen at HAT time ``now``: the bytes the ring
        holds when it has arrived (itself included)."""
        arrived = max(now, self._arrived) + size / WIRE_BYTES_PER_MS
        self._arrived = arrived
        while self._queued and self._queued[0][0] <= arrived:
            self._held -= self._queued.popleft()[1]
        self._busy = max(arrived, self._busy) + cost_ms
        self._queued.append((self._busy, size))
        self._held += size
        return self._held


def line_cost_ms(profile: Any, raw: bytes, commands: List[str], hat: Optional[Any]) -> float:
    """What running ``raw`` costs the HAT's main loop, in ms: the profile's cost model (the default
    release's when ``profile`` is None); a ``list`` costs the dump of ``hat``'s ports as they are now
    (without a HAT to ask, the four ports' fixed cost only)."""
    cost = PassCost((profile if profile is not None else get_profile()).features)
    us = cost.line_us + cost.text_byte_us * len(raw)
    lists = commands.count("list")
    if lists:
        ports = getattr(hat, "ports", None)
        list_us = cost.list_us(ports)[0] if ports else cost.list_port_us * _PORTS
        us += lists * list_us
    return us / 1000.0
