"""The command UART: the firmware's RX/TX rings and, optionally, the wire's pace.

FIRMWARE-BEHAVIOUR.md#fb-uart, #fb-tx-ring: RX and TX rings of 8192 bytes (the bootloader's are 4096);
a byte that arrives when the RX ring is full is dropped, and an output byte is dropped when the TX ring
is full. With ``baud=None`` the wire is infinitely fast: host bytes land in the RX ring at
once and output is readable as soon as the firmware writes it (the TX ring never fills).
With a baud rate, both directions move ``baud / 10`` bytes per second of virtual time
(8N1), so the TX ring fills the way it does on the HAT (report throttle, dropped output).
"""
from __future__ import annotations

from collections import deque
from typing import Optional

__all__ = ["Uart", "RING_SIZE", "HOST_BUFFER_LIMIT", "WIRE_AHEAD"]

RING_SIZE = 8192
# Output nobody reads (Python API) and input the wire has not carried yet are kept up to
# this size; beyond it the oldest output / newest input is dropped so memory stays bounded.
HOST_BUFFER_LIMIT = 4 * 1024 * 1024
_BYTE_COST = 10000  # credit units per byte: baud credits per ms, 10 bits per byte
# Paced mode: host bytes accepted ahead of the wire, at least WIRE_AHEAD or what the wire carries in
# WIRE_AHEAD_MS (a real-time runner may wake a few ms late on a loaded machine and must not fall below
# the wire rate). A runner takes no more than this from its link, so the link (a pty's kernel buffer, a
# TCP window) fills and pushes back on the host.
WIRE_AHEAD = 16
WIRE_AHEAD_MS = 8


class Uart:
    """One serial link between the host and the firmware (virtual time, 1 ms ticks)."""

    def __init__(self, rx_size: int = RING_SIZE, tx_size: int = RING_SIZE, baud: Optional[int] = None):
        if baud is not None and baud <= 0:
            raise ValueError(f"baud must be positive, got {baud}")
        self.baud = baud
        self.rx_size, self.tx_size = rx_size, tx_size
        self.rx: deque = deque()          # firmware RX ring
        self.tx: deque = deque()          # firmware TX ring (paced mode only)
        self._wire_in = bytearray()       # host bytes not yet on the wire (paced mode)
        self._out = bytearray()           # bytes delivered to the host, not yet read
        self._credit_in = self._credit_out = 0
        self.rx_dropped = self.tx_dropped = 0

    def resize(self, rx_size: int, tx_size: int) -> None:
        """A reboot into code with other ring sizes: the rings start empty."""
        self.rx_size, self.tx_size = rx_size, tx_size
        self.rx.clear()
        self.tx.clear()

    # -- host side -----------------------------------------------------------------------
    def host_write(self, data: bytes) -> None:
        if self.baud is None:
            self._receive(data)
        else:
            room = HOST_BUFFER_LIMIT - len(self._wire_in)
            self._wire_in += data[:max(room, 0)]

    def host_room(self) -> Optional[int]:
        """How many host bytes to accept now: None (any number) unpaced; paced, what keeps at most
        a few milliseconds of bytes waiting for the wire."""
        if self.baud is None:
            return None
        ahead = max(WIRE_AHEAD, self.baud * WIRE_AHEAD_MS // _BYTE_COST)
        return max(0, ahead - len(self._wire_in))

    def host_read(self) -> bytes:
        if not self._out:
            return b""          # the real-time loop asks after every pass
        out = bytes(self._out)
        self._out.clear()
        return out

    def host_pending(self) -> int:
        """Output bytes delivered to the host side and not yet read."""
        return len(self._out)

    # -- firmware side -------------------------------------------------------------------
    def rx_available(self) -> int:
        return len(self.rx)

    def read_byte(self) -> Optional[int]:
        return self.rx.popleft() if self.rx else None

    def write(self, data: bytes) -> None:
        """Firmware output. Bytes that do not fit in the TX ring are dropped (#fb-tx-ring)."""
        if self.baud is None:
            self._deliver(data)
            return
        room = self.tx_size - len(self.tx)
        if room < len(data):
            self.tx_dropped += len(data) - max(room, 0)
            data = data[:max(room, 0)]
        self.tx.extend(data)

    def tx_pending(self) -> int:
        """Bytes waiting in the TX ring (always 0 with an infinitely fast wire)."""
        return len(self.tx)

    # -- time ----------------------------------------------------------------------------
    def tick(self) -> None:
        """One millisecond of wire time (paced mode): move bytes both ways."""
        self.tick_in()
        self.tick_out()

    def tick_in(self) -> None:
        """One millisecond of the host-to-HAT wire (paced mode)."""
        if self.baud is None:
            return
        self._credit_in = min(self._credit_in + self.baud, self.baud + _BYTE_COST)
        n = min(self._credit_in // _BYTE_COST, len(self._wire_in))
        if n:
            self._receive(bytes(self._wire_in[:n]))
            del self._wire_in[:n]
            self._credit_in -= n * _BYTE_COST

    def tick_out(self, share: float = 1.0) -> None:
        """``share`` of a millisecond of the HAT-to-host wire (paced mode). The firmware runs
        half of it before its millisecond's work and half after: what it wrote starts to leave
        in the same millisecond, half-way through on average, as the chip's UART sends as soon
        as a byte is in its ring (lines then reach the host within a millisecond of where the
        firmware in the loop's do: docs/EMULATOR-MODELS.md "Start-up timeline")."""
        if self.baud is None:
            return
        self._credit_out = min(self._credit_out + int(self.baud * share), self.baud + _BYTE_COST)
        n = min(self._credit_out // _BYTE_COST, len(self.tx))
        if n:
            self._deliver(bytes(self.tx.popleft() for _ in range(n)))
            self._credit_out -= n * _BYTE_COST

    def idle(self) -> bool:
        """True when no byte is in flight in either direction."""
        return not (self._wire_in or self.tx)

    def quiet(self) -> bool:
        """True when :meth:`tick` would change nothing: no pace, or nothing in flight and both
        directions' credit already at its cap."""
        if self.baud is None:
            return True
        cap = self.baud + _BYTE_COST
        return self.idle() and self._credit_in == cap and self._credit_out == cap

    # -- internals -----------------------------------------------------------------------
    def _receive(self, data: bytes) -> None:
        room = self.rx_size - len(self.rx)
        if room < len(data):
            self.rx_dropped += len(data) - max(room, 0)
            data = data[:max(room, 0)]
        self.rx.extend(data)

    def _deliver(self, data: bytes) -> None:
        self._out += data
        excess = len(self._out) - HOST_BUFFER_LIMIT
        if excess > 0:
            del self._out[:excess]
