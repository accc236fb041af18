"""The real-time clock (wall -> virtual ms, --speed, no drift) and the control handler, in-process.

The wall clock is injected, so nothing here depends on real timing.
"""
from __future__ import annotations

import json
import os
from typing import Any, List, Optional, Tuple

import pytest

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.serving.control_channel import ControlHandler, parse_control_address
from buildhat_conformance.serving.realtime.clock import MAX_CATCH_UP_MS, RealTimeClock
from buildhat_conformance.serving.realtime.loop import run_realtime


class FakeWall:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def run(clock: RealTimeClock) -> int:
    n = clock.due()
    clock.done(n)
    return n


def test_clock_has_no_drift_at_any_speed():
    wall = FakeWall()
    clock = RealTimeClock(speed=10, now=wall)
    total = 0
    for _ in range(1000):           # irregular wake-ups never accumulate error
        wall.t += 0.000737
        total += run(clock)
    # floor(W * 1000 * speed) for the whole wall time W (per-wake-up rounding would give 7000)
    assert total == int((wall.t - 1000.0) * 1000 * 10)
    assert 7360 < total <= 7370
    assert clock.ticks == total


def test_clock_speed_change_keeps_ticks_and_catch_up_is_bounded():
    wall = FakeWall()
    clock = RealTimeClock(speed=1, now=wall)
    wall.t += 0.5
    assert run(clock) == 500
    clock.set_speed(4)
    assert run(clock) == 0                      # no jump when the speed changes
    wall.t += 0.25
    assert run(clock) == 1000
    wall.t += 100                               # the process was stopped for a while
    assert run(clock) == MAX_CATCH_UP_MS
    assert clock.seconds_until_next() == 0.0
    with pytest.raises(ValueError):
        RealTimeClock(speed=0)


def test_control_handler_replies():
    emu = Emulator(firmware="R7", devices={0: None, 1: None, 2: None})
    wall = FakeWall()
    handler = ControlHandler(emu, RealTimeClock(2, now=wall))
    assert handler("@time") == "ok 0"
    assert handler("@settled") == "ok 0"
    emu.boot()
    assert handler("@settled") == "ok 1"
    assert handler("@speed") == "ok 2"
    assert handler("@speed 8") == "ok 8"
    assert handler("@speed x").startswith("error ")
    assert handler("@lint").startswith("error ")           # no lint attached
    assert handler("").startswith("error ")
    assert handler("@plug 3 passive 8") == "ok"
    assert handler("@plug 3 0x99").startswith("error ") and "0x99" in handler("@plug 3 0x99")
    assert handler("@reset bootloader") == "ok"
    assert handler("@firmware") == "ok bootloader"
    assert ControlHandler(emu)("@speed").startswith("error ")   # virtual time: no speed


def test_control_handler_lint_reply_is_one_json_line():
    from buildhat_conformance.serving.host_lint.lint import HostLint
    emu = Emulator(firmware="R7", devices={0: None, 1: None, 2: None})
    lint = HostLint.for_hat(emu.hat)
    emu.boot()
    emu.write(b"bias 1\r")
    reply = ControlHandler(emu, lint=lint)("@lint")
    assert reply.startswith("ok {") and "\n" not in reply
    assert json.loads(reply[3:])["counts"]["error"] == 1


def test_control_addresses():
    assert parse_control_address("tcp:127.0.0.1:5000") == ("tcp", ("127.0.0.1", 5000))
    assert parse_control_address("tcp:5000") == ("tcp", ("127.0.0.1", 5000))
    assert parse_control_address("/tmp/x.sock") == ("unix", "/tmp/x.sock")
    with pytest.raises(ValueError):
        parse_control_address("tcp:host:notaport")


class _PipeLink:
    """The host side of the real-time runner without a pty: the host's bytes wait in a pipe
    (so select() sees them), what the HAT sends is kept with the fake wall time it left at."""

    def __init__(self, wall: FakeWall, host_bytes: bytes) -> None:
        self.wall = wall
        self.rd, wr = os.pipe()
        os.write(wr, host_bytes)
        os.close(wr)
        self.sent: List[Tuple[float, bytes]] = []

    def readables(self, data: bool = True) -> list:
        return [self.rd] if data and self.rd is not None else []

    def on_readable(self, obj: Any, limit: int) -> bytes:
        assert self.rd is not None            # readables() offers it only while open
        data = os.read(self.rd, limit)
        if not data:                          # everything read: nothing more to watch
            os.close(self.rd)
            self.rd = None
        return data

    def writables(self) -> list:
        return []

    def send(self, data: bytes) -> None:
        self.sent.append((self.wall.t, data))

    def flush(self) -> None:
        pass

    def first(self, needle: bytes) -> Optional[float]:
        out = b""
        for t, data in self.sent:
            out += data
            if needle in out:
                return t
        return None


@pytest.mark.parametrize("lag_s", [0.0, 0.35, 1.5, 10.0],
                         ids=["on-time", "lag-350ms", "lag-1.5s", "stopped-10s"])
def test_a_line_read_while_the_runner_lags_is_timed_from_its_arrival(lag_s: float) -> None:
    """Issue 27: a loaded machine leaves the runner behind the wall clock. The host's `set pulse`
    must then start at the virtual ms it arrived, so its `done` (101 ticks for 1 s, FACTS §7.1)
    comes no sooner than 1 s of the host's clock after the host wrote it, however far behind the
    HAT was (handing it over first and catching up after ran the pulse in a fraction of that)."""
    emu = Emulator(firmware="R7", devices={0: "0x30", 1: None, 2: None, 3: None})
    emu.boot()
    emu.read()
    wall = FakeWall()
    clock = RealTimeClock(1, now=wall)
    link = _PipeLink(wall, b"port 0 ; set pulse 0 0 1 0\r")    # in the pipe at the start instant
    wall.t += lag_s                         # ... and the runner wakes up this late to read it

    def stop() -> bool:
        wall.t += 0.005                     # the wall moves on between looks (5 ms each)
        return link.first(b"pulse done") is not None or wall.t > 1000.0 + lag_s + 5

    run_realtime(emu, link, clock, should_stop=stop)
    done_at = link.first(b"pulse done")
    assert done_at is not None, b"".join(d for _t, d in link.sent)[-300:]
    read_at = 1000.0 + lag_s                # the earliest the runner could have read the line
    assert done_at - read_at >= 1.0, f"`pulse done` {done_at - read_at:.4f} s after the line was read"
    assert done_at - read_at <= 1.1, f"`pulse done` {done_at - read_at:.4f} s after the line was read"
