"""Baud pacing (``buildhat-emulator --baud``), checked in virtual time: both directions move at
the wire rate, the firmware's report throttle sees the backlog, the real-time runner hands the
host no more than the wire carried, and the fuzzer's link copes with lines split by the pace.
The real rate against the wall clock is measured by ``make bench`` only."""
from __future__ import annotations

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.emulator.runners.clock import RealTimeClock
from buildhat_conformance.emulator.runners.realtime import run_realtime

EMPTY = {0: None, 1: None, 2: None, 3: None}
PER_MS = 115200 / 10 / 1000          # 11.52 bytes a millisecond (8N1)


def _booted(firmware: str = "R7", devices=EMPTY) -> Emulator:
    emu = Emulator(firmware=firmware, devices=devices, baud=115200)
    emu.boot()
    emu.advance(50)
    emu.read()
    return emu


def test_input_reaches_the_firmware_at_the_wire_rate() -> None:
    emu = _booted()
    lines = []
    emu.hat.line_observers.append(lines.append)
    emu.write(b"port 0\r" * 200)                 # 1400 bytes: ~122 ms on the wire
    emu.advance(61)
    # About half of them crossed: 61 ms carry 702 bytes = 100 lines of 7 bytes.
    assert abs(len(lines) - 61 * PER_MS / 7) <= 2
    emu.advance(70)
    assert len(lines) == 200


def test_output_leaves_at_the_wire_rate() -> None:
    emu = _booted()
    emu.write(b"help\r")
    got = b""
    for ms in range(1, 301):
        emu.advance(1)
        got += emu.read()
        # Never ahead of the wire (5 input bytes first), never more than a byte behind it.
        assert len(got) <= (ms - 5 / PER_MS) * PER_MS + 2
        if ms > 10:
            assert len(got) >= (ms - 5 / PER_MS - 2) * PER_MS
    assert len(got) <= 2 + 4201


def test_report_throttle_follows_the_paced_backlog() -> None:
    # §6.2 / §11: R5+ print no report while the TX ring holds 4096 bytes or more. Two help
    # texts (8402 bytes, 8192 kept) fill it; on an infinitely fast wire it would stay empty.
    for firmware, throttles in (("R7", True), ("R1", False)):
        emu = _booted(firmware, devices={0: "0x30", 1: None, 2: None, 3: None})
        emu.write(b"port 0 ; select 1\r")
        emu.advance(300)
        emu.read()
        emu.write(b"help ; help\r")
        emu.advance(250)                          # the ring still holds > 5000 bytes
        assert emu.hat.tx_pending() > 4096
        # R1 queues its reports behind the help text (the wire has made room); R5+ hold them.
        assert (b"P0M1:" not in bytes(emu.uart.tx)) == throttles, firmware
        emu.advance(1000)                         # drained: reports come back
        assert b"P0M1:" in emu.read()[-200:]


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
    emu = _booted()
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


def test_fuzz_link_completes_a_prompt_split_by_the_wire() -> None:
    # With echo on the prompt follows the fence answer; on a paced wire it arrives a moment
    # later, and a line still crossing at the fence belongs to the next answer.
    from buildhat_conformance.emulator.inprocess_target import InProcessTarget
    from buildhat_conformance.fuzz.link import FENCE, Link

    target = InProcessTarget(firmware="R7", devices=EMPTY, baud=115200)
    target.open()
    link = Link(target, "paced")
    link.drain()
    fence_line = b"Firmware version: " + target.emulator.hat.version_string.encode() + b"\r\n"
    link.exchange(b"echo 1\r", fence_line, 1)
    answers = link.exchange_batch([b"vin\r", b"port 1\r"], fence_line, [1, 1])
    for answer in answers:
        assert answer.endswith(fence_line + b"P0>") or answer.endswith(fence_line + b"P1>"), answer
    assert answers[0].startswith(b"vin\r\n") and FENCE in answers[0]
