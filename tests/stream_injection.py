"""A HAT whose `debug 16` stream lands a line in the middle of what it is echoing: the in-process
emulator behind a tee that puts a PID line right after given bytes of its output (the timing a
real HAT shows at random, made exact). Shared by the fence and torn-echo tests."""
from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Iterator, Tuple

from buildhat_conformance.conformance.hat_under_test import HatUnderTest
from buildhat_conformance.conformance.tee import VirtualTeeTarget
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target

PID_LINE = b"P0: pv=96.0000 sp=0.00000: e=96.0000 ie=0.00000 de=0.00000 cv=-0.00000\r\n"


class StreamLineAfter(VirtualTeeTarget):
    """Puts :data:`PID_LINE` into the output each time it has just passed ``marker``."""

    def __init__(self, inner: Any, marker: bytes) -> None:
        super().__init__(inner)
        self.marker = marker
        self.injected = 0
        self._tail = b""

    def read(self, timeout: float) -> bytes:
        out = bytearray()
        for b in super().read(timeout):
            out.append(b)
            self._tail = (self._tail + bytes([b]))[-len(self.marker):]
            if self._tail == self.marker:
                out += PID_LINE
                self.injected += 1
        return bytes(out)


@contextmanager
def echoing_hat(marker: bytes) -> Iterator[Tuple[HatUnderTest, StreamLineAfter]]:
    """The in-process R7 HAT behind :class:`StreamLineAfter`, in step and with echo on."""
    target = StreamLineAfter(make_target("inprocess:R7"), marker)
    session = Session(target)
    session.open()
    try:
        hat = HatUnderTest(session, target, "inprocess:R7")
        hat.resync()
        hat.exchange("echo 1")
        yield hat, target
    finally:
        session.close()
