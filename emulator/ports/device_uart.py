"""The HAT's UART on one device port (FIRMWARE-BEHAVIOUR.md#fb-lpf2-receive, #fb-debug bit 1).

``Port`` (emulator/ports/port.py) owns the wire: the bytes the device sends arrive on it at the
device's baud rate. Each byte that has arrived goes to :meth:`PortUart.receive`, the port's
receive interrupt: while the UART is off bytes are lost; after it is switched on, bytes count
only after ``SYNC_GAP_MS`` of silence; then they are framed into LPF2 messages, which queue in
a 4-slot message queue (``MQ overrun!`` when a fifth completes before the port's main-loop pass
takes one: the emulated main loop drains the queue once per millisecond). Debug bit 1 traces
every byte with the receiver state it met. :meth:`PortUart.transmit` is the other direction:
a HAT frame as the device's own receiver takes it apart.
"""
from __future__ import annotations

from collections import deque
from typing import Deque, List

from ..services import UartServices
from . import lpf2

__all__ = ["PortUart", "SYNC_GAP_MS", "QUEUE_SLOTS", "SETUP_BAUD", "MIN_BAUD", "MAX_BAUD"]

SYNC_GAP_MS = 100           # receive sync: bytes are ignored until a gap this long
QUEUE_SLOTS = 4
SETUP_BAUD = 2400
MIN_BAUD, MAX_BAUD = 2400, 115200


class PortUart:
    """Receive sync, LPF2 framing and the message queue of one port (see the module docstring)."""

    def __init__(self, hat: UartServices, index: int) -> None:
        self.hat = hat          # the HAT as far as the UART may use it
        self.index = index
        self.on = False
        self.baud = SETUP_BAUD
        self.queue: Deque[lpf2.Message] = deque()
        self._rx = lpf2.Assembler()
        self._synced = False
        self._last = 0.0        # arrival time of the last byte seen
        self._tx = lpf2.Assembler(keep_system=True)

    def start(self, now: int, baud: int = SETUP_BAUD) -> None:
        """Switch on at the setup baud rate (the profile's ``device_setup`` baud: the facts do
        not give it), waiting for sync again."""
        self.on = True
        self.baud = baud
        self._rx.reset()
        self._synced = False
        self._last = float(now)
        self.queue.clear()

    def stop(self) -> None:
        self.on = False
        self.queue.clear()

    def switch_baud(self, baud: int) -> None:
        """The handshake's baud switch, to the device's rate within what the UART can do."""
        self.baud = max(MIN_BAUD, min(MAX_BAUD, baud))

    def receive(self, t: float, b: int) -> None:
        """Byte ``b`` arrived at virtual time ``t``."""
        if not self.on:
            return
        if not self._synced:
            gap = t - self._last
            self._last = t
            if gap < SYNC_GAP_MS:
                self._trace(b, "n")
                return
            self._synced = True
        self._last = t
        state = self._rx.state
        msg = self._rx.feed(b)
        self._trace(b, "ACK" if msg is not None and msg.header == lpf2.ACK else state)
        if msg is None:
            return
        self.hat.event("devrx", port=self.index, hex=msg.hex())
        if len(self.queue) >= QUEUE_SLOTS:
            self.hat.emit("MQ overrun!")
            return
        self.queue.append(msg)

    def transmit(self, frame: bytes) -> List[lpf2.Message]:
        """The messages a device's receiver makes of ``frame`` (system bytes included)."""
        self._tx.reset()
        out: List[lpf2.Message] = []
        for b in frame:
            msg = self._tx.feed(b)
            if msg is not None:
                out.append(msg)
        return out

    def _trace(self, b: int, state: str) -> None:
        if self.hat.debug & 1:
            self.hat.write_out(f"{b:02X}{state}".encode("ascii"))
