"""A test helper: an in-process emulator advanced 1 ms at a time, keeping every output line
with the virtual millisecond it arrived in, and the device-side events."""
from __future__ import annotations

from typing import Dict, List, Optional, Tuple

from buildhat_conformance.emulator.api import Emulator


class Tap:
    def __init__(self, emu: Emulator):
        self.emu = emu
        self.buf = b""
        self.lines: List[Tuple[int, str]] = []

    def run(self, ms: int) -> List[Tuple[int, str]]:
        """Advance ``ms`` milliseconds; return the (t, line) pairs that completed meanwhile."""
        new = []
        for _ in range(ms):
            self.emu.advance(1)
            self.buf += self.emu.read()
            while b"\r\n" in self.buf:
                line, self.buf = self.buf.split(b"\r\n", 1)
                new.append((self.emu.now, line.decode("latin-1")))
        self.lines += new
        return new

    def times(self, text: str) -> List[int]:
        return [t for t, line in self.lines if line == text]

    def send(self, text: str) -> int:
        self.emu.write(text.encode("ascii") + b"\r")
        return self.emu.now

    def dev(self, port: int, since: int) -> list:
        """Frames the HAT sent to the device on ``port`` since ``since`` (NACK keep-alives left out)."""
        return [e for e in self.emu.events
                if e["dir"] == "dev" and e["port"] == port and e["t"] >= since and e["hex"] != "02"]

    def devrx(self, port: int, since: int) -> list:
        return [e for e in self.emu.events
                if e["dir"] == "devrx" and e["port"] == port and e["t"] >= since]


def motor_on_p3(firmware: str = "R7", extra: Optional[Dict[int, str]] = None) -> Tap:
    """A booted emulator with a SPIKE medium motor (0x30) on P3 only, P3 selected."""
    layout = {0: "none", 1: "none", 2: "none", 3: "0x30"}
    layout.update(extra or {})
    emu = Emulator(firmware=firmware, devices=layout)
    emu.boot()
    tap = Tap(emu)
    tap.run(1)
    tap.send("port 3")
    tap.run(5)
    return tap
