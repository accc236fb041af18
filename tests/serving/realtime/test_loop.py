"""The real-time runner under ``buildhat-emulator --baud`` (serving/realtime/loop.py), in virtual
time: it hands the host no more than the wire carried. The real rate against the wall clock is
measured by ``make bench`` only."""
from __future__ import annotations

from paced_emulator import PER_MS, booted

from buildhat_conformance.serving.realtime.clock import RealTimeClock
from buildhat_conformance.serving.realtime.loop import run_realtime


class _FakeLink:
    """What the real-time runner writes to, without file descriptors."""

    def __init__(self) -> None:
        self.sent = bytearray()

    def readables(self, data: bool = True):  # type: ignore[no-untyped-def]
        return []

    def writables(self):  # type: ignore[no-untyped-def]
        return []

    def send(self, data: bytes) -> None:
        self.sent += data

    def flush(self) -> None:
        pass


def test_realtime_runner_hands_over_only_what_the_wire_carried() -> None:
    # The process path of `buildhat-emulator --baud 115200`: the runner's clock is driven by a
    # fake time source (5 ms per look), so this runs in virtual time; select() only sleeps.
    emu = booted()
    fake = [0.0]

    def now() -> float:
        fake[0] += 0.005
        return fake[0]

    clock = RealTimeClock(1.0, now=now)
    link = _FakeLink()
    emu.write(b"help\r")
    start = emu.now
    run_realtime(emu, link, clock, should_stop=lambda: emu.now - start >= 200)
    elapsed = emu.now - start
    assert len(link.sent) <= elapsed * PER_MS + 2
    assert len(link.sent) >= (elapsed - 10) * PER_MS
