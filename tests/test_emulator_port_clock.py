"""The real-time clock (wall -> virtual ms, --speed, no drift) and the control handler, in-process.

The wall clock is injected, so nothing here depends on real timing.
"""
from __future__ import annotations

import json

import pytest

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.emulator.control import ControlHandler, parse_control_address
from buildhat_conformance.emulator.runners.clock import MAX_CATCH_UP_MS, RealTimeClock


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
    from buildhat_conformance.emulator.hostlint import HostLint
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
