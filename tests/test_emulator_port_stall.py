"""Main-loop stall lines (`deltat=`, FIRMWARE-FACTS §5) from the pass cost model, in virtual time.

§5: "`deltat=XXXXXXXX` (8 upper-case hex digits) whenever one main-loop pass took more than
2 ms ... each pass computes deltat = gettick() - t0 (ms since the last pass), prints the line
if deltat > 2, then advances t0 and every timer by deltat (so the timers lose nothing)" and
"Observed on a real HAT: `deltat=00000003` as the line right after the `list` output for three
active devices (a motor, a distance sensor, a colour sensor)".
"""
from __future__ import annotations

import re

import pytest

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.protocol.profiles import profile_numbers

from .emulator_tap import Tap

DELTAT = re.compile(r"deltat=[0-9A-F]{8}")
THREE = {0: "0x30", 1: "0x3E", 2: "0x3D", 3: "none"}     # motor, distance, colour


def booted(layout, firmware="R7") -> Tap:
    emu = Emulator(firmware=firmware, devices=layout)
    emu.boot()
    emu.read()
    return Tap(emu)


@pytest.mark.parametrize("firmware", profile_numbers())
@pytest.mark.parametrize("motor", ["0x30", "0x31", "0x4B", "0x26"])
def test_list_of_three_active_devices_is_followed_by_deltat_3(firmware, motor):
    tap = booted({**THREE, 0: motor}, firmware)
    tap.send("list")
    tap.run(10)
    lines = [line for _, line in tap.lines]
    last = lines.index("P3: no device detected")
    assert lines[last + 1] == "deltat=00000003"
    assert [x for x in lines if DELTAT.fullmatch(x)] == ["deltat=00000003"]


def test_cheap_commands_and_a_short_list_print_no_stall_line():
    tap = booted({0: "none", 1: "none", 2: "none", 3: "none"})
    tap.send("version ; vin ; list ; port 2 ; echo 0")
    tap.run(20)
    assert not [line for _, line in tap.lines if line.startswith("deltat")]


def test_the_stalled_pass_delays_the_next_line_and_the_reports():
    # The command runs at the end of its pass; the next pass starts with the stall line, so
    # input after `list` is handled after it, and nothing the loop does runs in between.
    tap = booted(THREE)
    tap.send("port 0 ; select 1 ; selrate 1")       # a report every millisecond
    tap.run(50)
    t = tap.send("list")
    tap.emu.write(b"version\r")                      # arrives while the HAT is busy
    tap.run(10)
    after = [(tt, line) for tt, line in tap.lines if tt >= t]
    texts = [line for _, line in after]
    end = texts.index("P3: no device detected")
    assert texts[end + 1] == "deltat=00000003"
    assert texts[end + 2] == ""                      # the CRLF of the next line's CR (§1) ...
    assert texts[end + 3].startswith("Firmware version: ")   # ... and its output
    t_stall = after[end + 1][0]
    assert t_stall == t + 3                          # in virtual time: 3 ms later
    reports = [tt for tt, line in after if line.startswith("P0M1:")]
    assert reports and not [tt for tt in reports if t < tt < t_stall]
