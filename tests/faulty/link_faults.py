"""Faults of the HAT as a device, not of its protocol: the link or the board misbehaving.

Same design as tests/planted/faults.py (a filter on host lines and HAT output, knowing nothing
of the emulator), for the faults a release engineer meets on hardware: one byte lost or corrupted
(a line ending), a restart, silence, a HAT that stops reading, a flood of lines, binary garbage,
an exit. Each fires once the host has sent ``after`` lines (CRs), i.e. mid-run, at the first
host line from there on that starts with ``on`` when that is given (a line of a test case,
not of the harness's own set-up between cases). The program
around it is faulty_hat.py.
"""
from __future__ import annotations

import random
from typing import Optional

__all__ = ["LinkFault", "KINDS"]

KINDS = ("drop", "corrupt", "reboot", "silent", "deaf", "flood", "garbage", "exit")


class LinkFault:
    """When the fault fires and what it does to the HAT's output bytes."""

    def __init__(self, kind: str, after: int = 40, seed: int = 13, on: Optional[bytes] = None):
        if kind not in KINDS:
            raise ValueError(f"unknown link fault {kind!r} ({', '.join(KINDS)})")
        self.kind = kind
        self.after = after
        self.on = on               # fire at the first host line (after ``after``) starting so
        self.host_lines = 0
        self.fired = False
        self.done = False          # a one-shot fault (drop, corrupt, reboot, garbage) has happened
        self.rng = random.Random(seed)

    def host(self, data: bytes) -> bool:
        """Count host lines; True the moment the fault fires."""
        if self.fired:
            return False
        for line in data.split(b"\r")[:-1]:
            self.host_lines += 1
            if self.host_lines >= self.after and (self.on is None or line.startswith(self.on)):
                self.fired = True
                return True
        return False

    def output(self, data: bytes) -> bytes:
        """The HAT's output as the host receives it."""
        if not self.fired or self.done:
            return b"" if self.fired and self.kind == "silent" else data
        if self.kind == "silent":
            return b""
        if self.kind in ("drop", "corrupt"):
            i = data.find(b"\n")
            if i < 0:
                return data
            self.done = True
            # A lost LF, or the same byte with one bit flipped (0x0A -> 0x8A): a line ending gone.
            return data[:i] + data[i + 1:] if self.kind == "drop" else data[:i] + b"\x8a" + data[i + 1:]
        return data

    def flood_lines(self, n: int, start: int) -> bytes:
        """``n`` lines no Build HAT prints (a babbling device on the port)."""
        return b"".join(b"FLOOD %06d the quick brown fox jumps over the lazy dog\r\n" % (start + k)
                        for k in range(n))

    def garbage(self, size: int) -> bytes:
        """Binary noise: every byte value, no line structure."""
        return self.rng.randbytes(size)


