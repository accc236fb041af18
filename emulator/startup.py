"""Firmware start-up on the command port (FIRMWARE-FACTS §1 last part, §5, §10).

Banner at power-on; then input is read and thrown away at one byte per 10 ms for as long as
bytes keep coming; ``Initialising ports``; 100 ms; the driver resets; 100 ms; the driver
dumps and ``Done initialising ports``. Bytes that arrive after the discard phase stay in
the RX ring and are processed when the main loop starts.
"""
from __future__ import annotations

from .services import StartupServices

__all__ = ["Startup", "BANNER", "DONE_LINE"]

BANNER = (b"", b"Type help <RETURN> for help")
DONE_LINE = b"Done initialising ports"
_DISCARD_INTERVAL = 10
_STEP = 100
_DRIVERS = b"0123"


class Startup:
    """Runs the start-up as a small schedule; ``done`` turns True with the main loop."""

    def __init__(self, hat: StartupServices):
        self.hat = hat          # the HAT as far as the start-up may use it
        self.done = False
        self.discarded = 0          # input bytes thrown away by the discard loop
        for line in BANNER:
            hat.emit(line)
        self._stage = "discard"
        self._at = hat.now + _DISCARD_INTERVAL

    def tick(self) -> None:
        hat = self.hat
        if self.done or hat.now < self._at:
            return
        if self._stage == "discard":
            if hat.uart.read_byte() is not None:
                self.discarded += 1
                self._at = hat.now + _DISCARD_INTERVAL
                return
            hat.emit(b"Initialising ports")
            self._stage, self._at = "reset", hat.now + _STEP
        elif self._stage == "reset":
            hat.write_out(b"Resetting drivers: ")
            for digit in _DRIVERS:      # one digit per driver as it is reset
                hat.write_out(bytes((digit,)))
            hat.write_out(b"\r\n")
            self._stage, self._at = "dumps", hat.now + _STEP
        elif self._stage == "dumps":
            for when in (b"before", b"after"):
                hat.write_out(b"Reading driver dumps: " + when + b" port_initdriver(): ")
                for digit in _DRIVERS:
                    hat.write_out(bytes((digit,)))
                hat.write_out(b"\r\n")
            hat.emit(DONE_LINE)
            self.done = True
