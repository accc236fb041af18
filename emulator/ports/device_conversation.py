"""The HAT's conversation with one active device, from setup to the data phase
(FIRMWARE-BEHAVIOUR.md#fb-active, #fb-device-messages).

``Port`` (emulator/ports/port.py) detects the device and prints ``connecting to active device``; it
then starts an ``DeviceConversation`` and ticks it every millisecond until the link ends. Setup
messages fill a :class:`DeviceInfo`; the device's ACK starts the handshake: +10 ms SPEED,
+100 ms ACK, +10 ms baud switch (``set baud rate to <baud>``, no prefix), +1 ms the ``list``
dump and ``P<p>: established serial communication with active ID xx``. In the data phase the
HAT sends NACK every 100 ms and handles one queued message per main-loop pass, running the
report engine after each (DATA payloads go to the port's mode store).

The link fails on a bad checksum during setup, after more than 2000 ms (setup) or 500 ms (data
phase) without a message, or on more than 5 bad messages in the data phase. :meth:`DeviceConversation.tick`
says how the millisecond ended and the port acts on it: None (carry on), ``ESTABLISHED``,
``RESTART`` (an ACK before any TYPE message: back to state 0 silently) or a :class:`Failure`,
whose text the port prints before it disconnects.
Debug bits (#fb-debug) printed here: 8 DATA payloads, 32 unknown messages.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Union

from ..commands.listing import active_dump
from ..devices.info import DeviceInfo
from ..services import LinkServices
from . import lpf2
from .data_reports import Reporter
from .device_uart import PortUart
from .mode_store import ModeStore

__all__ = ["DeviceConversation", "Failure", "ESTABLISHED", "RESTART", "SETUP_TIMEOUT_MS", "DATA_TIMEOUT_MS",
           "NACK_PERIOD_MS", "MAX_ERRORS", "HANDSHAKE_SPEED_MS", "HANDSHAKE_ACK_MS",
           "HANDSHAKE_SWITCH_MS", "HANDSHAKE_DUMP_MS"]

SETUP_TIMEOUT_MS = 2000
DATA_TIMEOUT_MS = 500
NACK_PERIOD_MS = 100
MAX_ERRORS = 5              # checksum + framing errors above this disconnect
HANDSHAKE_SPEED_MS = 10     # after the device's ACK
HANDSHAKE_ACK_MS = 110
HANDSHAKE_SWITCH_MS = 120
HANDSHAKE_DUMP_MS = 121

ESTABLISHED = "established"
RESTART = "restart"


@dataclass(frozen=True)
class Failure:
    text: str               # printed after ``P<p>: ``


Outcome = Union[None, str, Failure]


class DeviceConversation:
    """Setup, handshake and data phase of one connection (see the module docstring)."""

    def __init__(self, hat: LinkServices, index: int, uart: PortUart, modes: ModeStore,
                 reporter: Reporter, send: Callable[[bytes], None], now: int) -> None:
        self.hat = hat          # the HAT as far as the link may use it
        self.index = index
        self.uart = uart
        self.modes = modes
        self.reporter = reporter
        self._send = send       # the port's send_to_device
        self.info = DeviceInfo()
        self.phase = "setup"    # then "handshake", "data"
        self._last_msg = now
        self._errors = 0
        self._handshake_at = now    # when the next handshake step is due
        self._handshake_step = 0
        self._next_nack = now

    def tick(self, now: int) -> Outcome:
        if self.phase == "data":
            return self._data_tick(now)
        return self._setup_tick(now)

    def next_due(self, now: int) -> float:
        """The first millisecond after ``now`` in which :meth:`tick` may do anything (a message
        in the queue is the port's to notice)."""
        if self.phase == "setup":
            # Only the timeout is the link's own; a message that arrives is the port's to notice.
            return max(now + 1, self._last_msg + SETUP_TIMEOUT_MS + 1)
        if self.phase == "handshake":
            return max(now + 1, self._handshake_at)     # the next step's own due time
        return min(self.reporter.next_due(now), self._next_nack,
                   self._last_msg + DATA_TIMEOUT_MS + 1)

    # -- setup and handshake -------------------------------------------------------------------
    def _setup_tick(self, now: int) -> Outcome:
        if self.phase == "setup":
            queue = self.uart.queue
            while queue:
                msg = queue.popleft()
                self._last_msg = now
                if not msg.ok:
                    return Failure("checksum error: disconnecting")
                if msg.header == lpf2.ACK:
                    if self.info.type_id is None:
                        return RESTART
                    self.phase = "handshake"
                    self._handshake_at = now + HANDSHAKE_SPEED_MS
                    self._handshake_step = 0
                    break
                self._setup_message(msg)
            if self.phase == "setup":
                if now - self._last_msg > SETUP_TIMEOUT_MS:
                    return Failure("timeout during setup phase: disconnecting")
                return None
        # Each step waits its delay from the step before (the firmware's per-port delay): a step
        # that runs late, e.g. after a main-loop stall (#fb-stall), shifts the ones after it.
        if now < self._handshake_at:
            return None
        baud = self.info.baud
        step = self._handshake_step
        self._handshake_step += 1
        if step == 0:
            self._send(lpf2.speed_frame(baud))
            self._handshake_at = now + HANDSHAKE_ACK_MS - HANDSHAKE_SPEED_MS
        elif step == 1:
            self._send(bytes([lpf2.ACK]))
            self._handshake_at = now + HANDSHAKE_SWITCH_MS - HANDSHAKE_ACK_MS
        elif step == 2:
            self.uart.switch_baud(baud)
            self.hat.emit(f"set baud rate to {baud}")
            self._handshake_at = now + HANDSHAKE_DUMP_MS - HANDSHAKE_SWITCH_MS
        else:
            self._establish(now)
            return ESTABLISHED
        return None

    def _setup_message(self, msg: lpf2.Message) -> None:
        if self.info.apply(msg) or not self.hat.debug & 32:
            return
        if msg.msg_class == lpf2.INFO:
            self._line(f"type=80 cmd={msg.cmd:02X}  payload={_payload_hex(msg.payload)}")
        else:
            self.hat.emit(f"P{self.index:X} message type={msg.header:02X}")

    def _establish(self, now: int) -> None:
        for line in active_dump(self.index, self.info):
            self.hat.emit(line)
        self._line(f"established serial communication with active ID {self.info.type_id:02X}")
        self.phase = "data"
        self._last_msg = now
        self._next_nack = now + NACK_PERIOD_MS

    # -- data phase ----------------------------------------------------------------------------
    def _data_tick(self, now: int) -> Outcome:
        # The main loop makes many passes per millisecond; each pass handles one queued
        # message and then runs the report engine (so rate 0 reports once per message).
        queue = self.uart.queue
        if not queue:
            self.reporter.tick(now)
        while queue:
            failure = self._data_message(queue.popleft(), now)
            if failure is not None:
                return failure
            self.reporter.tick(now)
        if now >= self._next_nack:
            self._next_nack += NACK_PERIOD_MS
            self._send(bytes([lpf2.NACK]))
        if now - self._last_msg > DATA_TIMEOUT_MS:
            return Failure("timeout during data phase: disconnecting")
        return None

    def _data_message(self, msg: lpf2.Message, now: int) -> Optional[Failure]:
        self._last_msg = now
        if not msg.ok:
            self._errors += 1
            if self._errors > MAX_ERRORS:
                return Failure(f"too many errors (0+{self._errors}): disconnecting")
            return None
        if msg.msg_class == lpf2.DATA:
            mode = msg.code
            self.modes.store(mode, msg.payload, now)
            if self.hat.debug & 8:
                self._line(f"DATA mode={mode:X} payload={_payload_hex(msg.payload)}")
            self.reporter.on_data(mode)
        elif self.hat.debug & 32:
            self._line(f"data-phase message type {msg.header:02X} payload={_payload_hex(msg.payload)}")
        return None

    def _line(self, text: str) -> None:
        self.hat.emit(f"P{self.index:X}: {text}")


def _payload_hex(payload: bytes) -> str:
    return " ".join(f"{b:02x}" for b in payload)
