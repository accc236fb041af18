"""Bytes to and from a target for ``load``: every byte in the transcript, and waits that say
what arrived when what was expected did not.

The bootloader protocol is not line-per-command like the firmware's (an upload is raw bytes
with no echo, the prompt has no line ending), so ``load`` reads the byte stream itself
rather than through the conformance session.
"""
from __future__ import annotations

import re
import time
from typing import Callable, Optional, Pattern, Union

from ..targets.base import Target, TargetError
from ..transcript import TranscriptWriter
from .errors import LoadError

__all__ = ["Wire"]

Match = Union[bytes, Pattern[bytes]]


class Wire:
    """A target's byte stream with a read position: ``send``, ``wait_for``, ``since_mark``."""

    def __init__(self, target: Target, transcript: Optional[TranscriptWriter] = None,
                 clock: Callable[[], float] = time.monotonic):
        self.target = target
        self.transcript = transcript
        self.clock = clock
        self.t0 = clock()
        self.received = bytearray()
        self.pos = 0                       # everything before it has been looked at

    def now_ms(self) -> float:
        return (self.clock() - self.t0) * 1000.0

    def send(self, data: bytes) -> None:
        if self.transcript is not None:
            self.transcript.host(self.now_ms(), data)
        try:
            self.target.write(data)
        except TargetError as exc:
            raise LoadError(_one_line(f"writing to {self.target.url} failed: {exc}")) from None

    def poll(self, timeout: float = 0.0) -> bytes:
        """Whatever arrives within ``timeout`` seconds (b"" if nothing)."""
        try:
            data = self.target.read(timeout)
        except TargetError as exc:
            raise LoadError(_one_line(str(exc))) from None
        if data:
            self.received += data
            if self.transcript is not None:
                self.transcript.hat(self.now_ms(), data)
        return data

    def skip(self) -> None:
        """Forget what arrived so far: later waits look only at newer bytes."""
        self.poll(0.0)
        self.pos = len(self.received)

    def drain(self, quiet: float = 0.1, limit: float = 1.0) -> None:
        """Read until ``quiet`` seconds pass with nothing new (at most ``limit``), then skip it."""
        end = self.clock() + limit
        while self.clock() < end and self.poll(quiet):
            pass
        self.pos = len(self.received)

    def wait_for(self, *patterns: Match, timeout: float) -> Optional[re.Match[bytes]]:
        """The first match of any pattern after the read position (which moves past it), or
        None after ``timeout`` seconds."""
        compiled = [p if isinstance(p, re.Pattern) else re.compile(re.escape(p)) for p in patterns]
        end = self.clock() + timeout
        while True:
            best: Optional[re.Match[bytes]] = None
            for rx in compiled:
                m = rx.search(self.received, self.pos)
                if m is not None and (best is None or m.start() < best.start()):
                    best = m
            if best is not None:
                self.pos = best.end()
                return best
            left = end - self.clock()
            if left <= 0:
                return None
            self.poll(min(left, 0.05))

    def recent(self, limit: int = 120) -> str:
        """The last bytes received, for a message."""
        tail = bytes(self.received[-limit:])
        return repr(tail) if tail else "nothing"


def _one_line(text: str) -> str:
    return " ".join(text.split())

