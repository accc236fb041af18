"""Firmware start-up on the command port (docs/FIRMWARE-BEHAVIOUR.md#fb-startup, #fb-boot-input).

Banner at power-on; then input is read and thrown away at one byte per 10 ms for as long as
bytes keep coming; ``Initialising ports``; 100 ms; the driver resets; 100 ms; the driver
dumps and ``Done initialising ports``. Bytes that arrive after the discard phase stay in
the RX ring and are processed when the main loop starts.

When each piece is written, counted from ``Initialising ports`` (the firmware in the loop,
docs/EMULATOR-MODELS.md "Start-up timeline"): each driver's digit of the two dump lines
comes as that driver's register dump is read over I2C (about 23.2 ms each), and the four
drivers are set up between the two lines (about 1.9 ms each). ``Done initialising ports``
thus comes about 393 ms after ``Initialising ports`` (403.4 ms after power-on), and the main
loop's 10 ms controller tick counts from its millisecond (tick 404: updates at 414, 424 ...).
"""
from __future__ import annotations

from typing import List, Optional, Tuple

from .services import StartupServices

__all__ = ["Startup", "BANNER", "DONE_LINE", "SCHEDULE_US"]

BANNER = (b"", b"Type help <RETURN> for help")
DONE_LINE = b"Done initialising ports"
_DISCARD_INTERVAL = 10
_STEP_US = 100_000          # the two 100 ms waits of the start-up
_DUMP_US = 23_226           # one driver's register dump read over I2C
_INIT_US = 1_895            # one driver's set-up, between the two dump lines
_DRIVERS = b"0123"
# The emulator's tick N stands for the firmware's millisecond (N-1, N]; the firmware writes
# ``Initialising ports`` about 30 µs into its millisecond, and the rest counts from there.
_PHASE_US = 30


def _schedule() -> List[Tuple[int, bytes]]:
    """(µs after ``Initialising ports``, bytes written then) for the rest of the start-up."""
    out: List[Tuple[int, bytes]] = [(_STEP_US, b"Resetting drivers: 0123\r\n")]
    at = 2 * _STEP_US
    for when in (b"before", b"after"):
        out.append((at, b"Reading driver dumps: " + when + b" port_initdriver(): "))
        for i, digit in enumerate(_DRIVERS):      # one digit as each driver's dump is read
            out.append((at + i * _DUMP_US, bytes((digit,))))
        at += len(_DRIVERS) * _DUMP_US
        out.append((at, b"\r\n"))
        if when == b"before":
            at += len(_DRIVERS) * _INIT_US
    out.append((at, DONE_LINE + b"\r\n"))
    return out


SCHEDULE_US = _schedule()


class Startup:
    """Runs the start-up as a small schedule; ``done`` turns True with the main loop."""

    def __init__(self, hat: StartupServices):
        self.hat = hat          # the HAT as far as the start-up may use it
        self.done = False
        self.done_at: Optional[int] = None      # the ms of ``Done initialising ports``
        self.discarded = 0          # input bytes thrown away by the discard loop
        for line in BANNER:
            hat.emit(line)
        self._discarding = True
        self._at = hat.now + _DISCARD_INTERVAL + 1
        self._init_ms = 0
        self._next = 0              # index into SCHEDULE_US

    def tick(self) -> None:
        hat = self.hat
        if self.done or hat.now < self._at:
            return
        if self._discarding:
            if hat.uart.read_byte() is not None:
                self.discarded += 1
                self._at = hat.now + _DISCARD_INTERVAL
                return
            hat.emit(b"Initialising ports")
            self._discarding, self._init_ms = False, hat.now
        while self._next < len(SCHEDULE_US) and self._tick_of(SCHEDULE_US[self._next][0]) <= hat.now:
            hat.write_out(SCHEDULE_US[self._next][1])
            self._next += 1
        if self._next == len(SCHEDULE_US):
            self.done, self.done_at = True, hat.now
            return
        self._at = self._tick_of(SCHEDULE_US[self._next][0])

    def _tick_of(self, offset_us: int) -> int:
        """The tick in which a piece ``offset_us`` after ``Initialising ports`` is written."""
        return self._init_ms - 1 + -(-(_PHASE_US + offset_us) // 1000)
