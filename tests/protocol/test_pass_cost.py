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
from emulator_tap import Tap

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.protocol.pass_cost import stall_line
from buildhat_conformance.protocol.profiles import profile_numbers

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


def test_a_handshake_survives_stalled_passes():
    # §5: a stalled pass delays what was due; the timers lose nothing, so every handshake step
    # still comes, in order, no earlier than §10's delays (ACK -> +10 SPEED -> +100 ACK -> +10
    # switch -> +1 established).
    tap = booted(THREE)
    tap.emu.world("@plug 3 0x30")

    def acked() -> bool:
        return any(e["dir"] == "devrx" and e.get("port") == 3 and e["hex"] == "04"
                   for e in tap.emu.events)
    while not acked():                                # the device's set-up stream
        tap.run(1)
    for _ in range(100):                              # a `list` (>= 3 ms) every 4 ms meanwhile
        tap.send("list")
        tap.run(4)
        if tap.times("P3: established serial communication with active ID 30"):
            break
    (t_est,) = tap.times("P3: established serial communication with active ID 30")
    rx = [e for e in tap.emu.events if e["dir"] == "devrx" and e.get("port") == 3]
    t_ack = [e["t"] for e in rx if e["hex"] == "04"][0]
    tx = [e for e in tap.emu.events if e["dir"] == "dev" and e.get("port") == 3 and e["t"] >= t_ack]
    assert tx[0]["hex"].startswith("52") and tx[1]["hex"] == "04"     # SPEED, then ACK
    (t_baud,) = tap.times("set baud rate to 115200")
    assert tx[0]["t"] - t_ack >= 10 and tx[1]["t"] - tx[0]["t"] >= 100
    assert t_baud - tx[1]["t"] >= 10 and t_est - t_baud >= 1
    assert [line for _, line in tap.lines if line.startswith("deltat=")]   # the passes did stall


@pytest.mark.parametrize("ms,line", [(3, b"deltat=00000003"), (255, b"deltat=000000FF"),
                                     (0xABCDEF12, b"deltat=ABCDEF12")])
def test_the_stall_line_is_deltat_and_eight_upper_case_hex_digits(ms, line):
    # §5: "`deltat=XXXXXXXX` (8 upper-case hex digits)"; the CRLF is the printer's.
    assert stall_line(ms) == line
