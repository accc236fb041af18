"""select / selonce / selrate / combi / write1 / write2 on the emulator, in virtual time.

Line formats are the §6.1 examples (FIRMWARE-FACTS, device 0x30 on P3); timing and SELECT
rules are §6.2 / §11 per profile; frames are §8's byte-exact examples.
"""
from __future__ import annotations

import re

import pytest
from emulator_tap import Tap, motor_on_p3

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.emulator.commands.device_commands import cmd_write1
from buildhat_conformance.emulator.commands.parser import Cursor
from buildhat_conformance.emulator.ports.data_reports import decode_values
from buildhat_conformance.protocol.profiles import get_profile

EMPTY = {0: "none", 1: "none", 2: "none", 3: "none"}
OLD = ["R1", "R2", "R3", "R4"]
NEW = ["R5", "R6", "R7"]


def first_report(tap: Tap, prefix: str, ms: int = 250) -> str:
    for _, line in tap.run(ms):
        if line.startswith(prefix):
            return line
    raise AssertionError(f"no line starting {prefix!r}")


# -- §6.1 line formats ------------------------------------------------------------------------
def test_mode_combi_and_variable_lines_match_the_facts_examples():
    tap = motor_on_p3()
    emu = tap.emu
    emu.world("@data 3 1 FB")
    tap.send("select 1")
    assert first_report(tap, "P3M1") == "P3M1: -5"
    tap.send("select 0")
    assert first_report(tap, "P3M0") == "P3M0:  0"
    emu.world("@data 3 2 10 27 00 00")
    tap.send("select 2")
    assert first_report(tap, "P3M2") == "P3M2: +10000"
    emu.world("@data 3 4 01 00 FF FF")
    tap.send("select 4")
    assert first_report(tap, "P3M4") == "P3M4: +1 -1"
    emu.world("@data 3 1 05")
    emu.world("@data 3 2 68 01 00 00")
    emu.world("@data 3 3 4C FF")
    tap.send("combi 0 1 0 2 0 3 0 ; select 0")
    assert first_report(tap, "P3C0") == "P3C0: +5 +360 -180"
    tap.send("select 3 0 s2")
    assert first_report(tap, "P3V") == "P3V: -180.000"
    tap.send("select 1 0 u1")
    assert first_report(tap, "P3V") == "P3V: 5.00000"


def test_float_values_use_the_firmware_printer():
    # §6.1 example `P3M6: 1.50000 -1.00000E-3 1.23457E8` (three float32 values).
    import struct
    payload = struct.pack("<fff", 1.5, -0.001, 123456789.0)
    assert decode_values(payload, 12, 3, 3) == ["1.50000", "-1.00000E-3", "1.23457E8"]
    # count is capped by the whole values that fit in the received length
    assert decode_values(payload, 8, 3, 3) == ["1.50000", "-1.00000E-3"]


def test_modes_8_to_15_send_select_but_never_print():
    tap = motor_on_p3(extra={3: "0x25"})
    t = tap.send("select 9")
    tap.run(400)
    frames = [e["hex"] for e in tap.dev(3, t)]
    assert frames == ["46 08 B1", "43 01 BD"]               # §8 `select 9`
    assert tap.devrx(3, t)                                  # the device does send data
    assert not [line for _, line in tap.lines if line.startswith("P3M")]


# -- §6.2 timing -------------------------------------------------------------------------------
def _first_data(tap: Tap, t: int, mode: int) -> int:
    for e in tap.devrx(3, t):
        header = int(e["hex"].split()[0], 16)
        if header & 0xC0 == 0xC0 and header & 7 == mode:
            return e["t"]
    raise AssertionError("device sent no data for the mode")


@pytest.mark.parametrize("firmware", OLD + NEW)
def test_select_reports_100ms_after_first_data_then_every_100ms(firmware):
    tap = motor_on_p3(firmware)
    t = tap.send("select 1")
    tap.run(460)
    t_data = _first_data(tap, t, 1)
    times = [tt for tt, line in tap.lines if line.startswith("P3M1:")]
    assert times[0] - t_data == 100
    assert {b - a for a, b in zip(times, times[1:])} == {100}


@pytest.mark.parametrize("firmware", OLD + NEW)
def test_selonce_first_report_per_profile(firmware):
    tap = motor_on_p3(firmware)
    t = tap.send("selonce 1")
    tap.run(400)
    t_data = _first_data(tap, t, 1)
    times = [tt for tt, line in tap.lines if line.startswith("P3M1:")]
    immediate = get_profile(firmware).feature("selonce_first_report") == "immediate"
    assert times == [t_data if immediate else t_data + 100]


@pytest.mark.parametrize("firmware", OLD + NEW)
def test_selonce_variable_form_repeats_on_r1_r4(firmware):
    tap = motor_on_p3(firmware)
    tap.send("selonce 2 0 s4")
    tap.run(450)
    times = [tt for tt, line in tap.lines if line.startswith("P3V:")]
    if firmware in OLD:
        assert len(times) >= 3 and {b - a for a, b in zip(times, times[1:])} == {100}
    else:
        assert len(times) == 1


@pytest.mark.parametrize("firmware", NEW)
def test_selrate_sets_the_period(firmware):
    tap = motor_on_p3(firmware)
    tap.send("select 2 ; selrate 10")
    tap.run(300)
    times = [tt for tt, line in tap.lines if line.startswith("P3M2:")]
    assert len(times) > 20 and {b - a for a, b in zip(times, times[1:])} == {10}


def test_selrate_is_an_error_before_r5():
    tap = motor_on_p3("R4")
    tap.send("selrate 10")
    assert "Error" in [line for _, line in tap.run(5)]


@pytest.mark.parametrize("firmware", OLD + NEW)
def test_select_resend_rules(firmware):
    tap = motor_on_p3(firmware)
    t = tap.send("sel 3")
    tap.run(20)
    tap.send("sel 3")
    tap.run(20)
    frames = [e["hex"] for e in tap.dev(3, t)]
    # SELECT mode 3: EXT_MODE `46 00 B9`, then `43 03` + checksum (0xFF ^ 0x43 ^ 0x03 = 0xBF).
    once = ["46 00 B9", "43 03 BF"]
    if get_profile(firmware).feature("select_resend") == "always":
        assert frames == once * 2
    else:
        assert frames == once
    # combi clears the selection on R5+, so the next select re-sends.
    t = tap.send("combi 1 ; sel 3")
    tap.run(20)
    frames = [e["hex"] for e in tap.dev(3, t)]
    assert frames[0].startswith("4C 20 01")
    assert frames[1:] == once


@pytest.mark.parametrize("firmware", ["R1", "R7"])
def test_select_with_bad_format_turns_reporting_off(firmware):
    tap = motor_on_p3(firmware)
    tap.send("select 1")
    tap.run(250)
    assert any(line.startswith("P3M1:") for _, line in tap.lines)
    t = tap.send("select 0 5")
    out = tap.run(400)
    assert [line for _, line in out][:2] == ["", "Error"]
    assert not [line for _, line in out if line.startswith("P3M")]
    assert tap.dev(3, t) == []                     # no SELECT sent


def test_combi_with_odd_count_rewrites_the_table_but_sends_nothing():
    tap = motor_on_p3()
    t = tap.send("combi 0 1 0 2")
    out = tap.run(5)
    assert [line for _, line in out] == ["", "Error"]
    assert tap.dev(3, t) == []
    tap.send("select 0")
    line = first_report(tap, "P3C0")
    assert re.fullmatch(r"P3C0: ( 0|[+-]\d+)", line)     # one value: the one pair parsed


def test_tx_throttle_on_r5_plus_only():
    for firmware, throttles in (("R7", True), ("R1", False)):
        tap = motor_on_p3(firmware)
        tap.emu.machine.tx_pending = lambda: 4096      # the TX ring holds 4096 bytes
        tap.send("select 2")
        out = tap.run(300)
        reports = [line for _, line in out if line.startswith("P3M2:")]
        assert (reports == []) == throttles


# -- §8 frames through the commands -------------------------------------------------------------
def test_write_and_combi_frames_are_byte_exact():
    tap = motor_on_p3()
    cases = [
        ("write1 c5 10 20 30 40", ["D5 10 20 30 40 6A"]),
        ("write1 c0 5", ["C0 05 3A"]),
        ("write1 40", ["40 00 BF"]),
        ("write2 44 11 22", ["44 11 22 88"]),
        ("write1 c2 12 23 34 45 12 23 34 45 12",
         ["E2 12 23 34 45 12 23 34 45 12 00 00 00 00 00 00 00 0F"]),
        ("combi 0 1 0 2 0 3 0", ["5C 23 00 10 20 30 00 00 00 80"]),
        ("combi 0", ["4C 20 00 93"]),
        ("select 0", ["46 00 B9", "43 00 BC"]),
        ("select 9", ["46 08 B1", "43 01 BD"]),
    ]
    for command, frames in cases:
        t = tap.send(command)
        out = tap.run(3)
        assert [e["hex"] for e in tap.dev(3, t)] == frames, command
        assert "Error" not in [line for _, line in out], command
    t = tap.send("combi 9 16 17")
    tap.run(3)
    (frame,) = tap.dev(3, t)
    assert frame["hex"].split()[1:4] == ["21", "07", "FF"]
    t = tap.send("write1 0x12")
    out = tap.run(3)
    assert [e["hex"] for e in tap.dev(3, t)] == ["00 00 FF"]
    assert "Error" in [line for _, line in out]


def test_write_payload_cap_and_write2_quirk():
    tap = motor_on_p3()
    # 128 payload tokens do not fit the 256-byte line buffer, so the cap is checked on the
    # command function itself: a 129th token is left for the command parser.
    hat = tap.emu.machine
    cur = Cursor(b"c0 " + b" ".join([b"1"] * 129))
    t = hat.now
    cmd_write1(hat, cur)
    (frame,) = tap.dev(3, t)
    assert len(frame["hex"].split()) == 1 + 128 + 1
    assert cur.rest() == b"1"
    tap.run(2)
    t = tap.send("write2 44 FFFFFFFF 11")
    tap.run(3)
    # A second token >= 2^31 means "no second byte": framed like `write1 44 11`.
    assert [e["hex"] for e in tap.dev(3, t)] == ["44 11 AA"]
    t = tap.send("write2 44")
    out = tap.run(3)
    assert tap.dev(3, t) == [] and "Error" in [line for _, line in out]


def test_nothing_reaches_an_empty_or_passive_port():
    tap = motor_on_p3(extra={2: "passive 8"})
    t = tap.send("port 2 ; write1 c0 5 ; select 1 ; combi 0 1 0 ; port 1 ; write1 c0 5")
    tap.run(300)
    assert [e for e in tap.emu.events if e["dir"] == "dev" and e["t"] >= t and e["port"] in (1, 2)] == []
    assert not [line for _, line in tap.lines if line.startswith(("P1M", "P2M", "P2C"))]


# -- device behaviour ----------------------------------------------------------------------------
def test_matrix_echoes_the_written_value():
    emu = Emulator(firmware="R7", devices={0: "none", 2: "none", 3: "none"})
    emu.boot()
    tap = Tap(emu)
    tap.send("port 1 ; select 1 ; write1 c1 5")
    assert first_report(tap, "P1M1:", 300) == "P1M1: +5"


def test_colour_sensor_measures_only_with_port_power():
    emu = Emulator(firmware="R7", devices={0: "0x3D", 1: "none", 2: "none", 3: "none"})
    emu.boot()
    tap = Tap(emu)
    tap.send("port 0 ; select 1")
    assert first_report(tap, "P0M1:") == "P0M1:  0"
    tap.send("plimit 1 ; set -1")
    tap.run(300)
    later = [line for _, line in tap.run(300) if line.startswith("P0M1:")]
    assert later and all(line != "P0M1:  0" for line in later)


def test_driven_motor_reports_speed_pos_and_consistent_apos():
    tap = motor_on_p3()
    tap.send("combi 0 1 0 2 0 3 0 ; select 0 ; selrate 10")
    rest = [line for _, line in tap.run(100) if line.startswith("P3C0:")]
    apos0 = int(rest[-1].split()[3])
    tap.send("plimit 1 ; set 0.5")
    values = [tuple(int(v) for v in line.split()[1:])
              for _, line in tap.run(1000) if line.startswith("P3C0:")]
    speeds = [v[0] for v in values[-20:]]
    assert all(s > 0 for s in speeds)
    pos = [v[1] for v in values]
    assert pos == sorted(pos) and pos[-1] > 180
    for _speed, p, apos in values:
        assert -180 <= apos <= 179
        expected = (apos0 + p + 180) % 360 - 180
        assert min((apos - expected) % 360, (expected - apos) % 360) <= 2


def test_motor_at_rest_sends_often_and_jitters_by_one():
    tap = motor_on_p3()
    t = tap.send("combi 0 1 0 2 0 3 0 ; select 0 ; selrate 0")
    out = tap.run(1000)
    rx = [e for e in tap.devrx(3, t) if int(e["hex"].split()[0], 16) & 0xC0 == 0xC0]
    assert len(rx) >= 1000 // 25                      # "every 5-25 ms" at rest
    apos = [int(line.split()[3]) for _, line in out if line.startswith("P3C0:")]
    assert max(apos) - min(apos) <= 2 and len(set(apos)) > 1


def test_runs_are_deterministic_for_a_seed():
    def run(seed):
        emu = Emulator(firmware="R7", devices={1: "none", 2: "none"}, seed=seed)
        emu.boot()
        emu.write(b"combi 0 1 0 2 0 3 0 ; select 0 ; selrate 0\r")
        emu.advance(500)
        return emu.read(), [e for e in emu.events if e["dir"] in ("dev", "devrx")]
    assert run(0) == run(0)


def test_debug_8_shows_data_payloads():
    tap = motor_on_p3()
    tap.emu.world("@data 3 1 FB")
    tap.send("select 1 ; debug 8")
    lines = [line for _, line in tap.run(250) if line.startswith("P3: DATA")]
    assert lines
    assert all(re.fullmatch(r"P3: DATA mode=[0-9A-F] payload=[0-9a-fA-F]{2}( [0-9a-fA-F]{2})*", x)
               for x in lines)
    assert any(x.lower() == "p3: data mode=1 payload=fb" for x in lines)


@pytest.mark.parametrize("firmware", ["R1", "R4", "R5", "R7"])
def test_reconnect_resets_select_state_on_r5_plus_only(firmware):
    tap = motor_on_p3(firmware)
    tap.send("combi 0 1 0 2 0 ; select 0")
    assert first_report(tap, "P3C0:").startswith("P3C0:")
    tap.emu.machine.ports[3].set_data_rate(600)        # starve the watchdog: timeout, reconnect
    tap.run(800)
    assert any(line == "P3: timeout during data phase: disconnecting" for _, line in tap.lines)
    tap.emu.machine.ports[3].set_data_rate(0)
    tap.run(3500)
    est = [t for t, line in tap.lines if line == "P3: established serial communication with active ID 30"]
    after = [line for t, line in tap.lines if est and t > est[-1] and line.startswith("P3")]
    reports = [line for line in after if line.startswith(("P3M", "P3C"))]
    if get_profile(firmware).feature("report_engine") == "fixed_100ms":
        # The selection survives; the combi record does not, and the device restarts in mode 0.
        assert reports and all(line == "P3M0:  0" for line in reports)
    else:
        assert reports == []
    tap.send("select 0")
    assert first_report(tap, "P3M0:") == "P3M0:  0"       # combi 0 was cleared by the reconnect


def test_debug_1_traces_received_bytes_with_state_letters():
    tap = motor_on_p3()
    tap.send("select 1 ; debug 1")
    tap.run(150)
    out = b"".join(line.encode("latin-1") for _, line in tap.lines) + tap.buf
    # A DATA message for mode 1 (1 byte payload): type byte `t`, payload and checksum `p`.
    assert re.search(rb"C1t[0-9A-F]{2}p[0-9A-F]{2}p", out)


def test_select_minus_one_selects_mode_0():
    tap = motor_on_p3()
    tap.send("select 9")
    tap.run(3)
    t = tap.send("select -1")
    tap.run(3)
    assert [e["hex"] for e in tap.dev(3, t)] == ["46 00 B9", "43 00 BC"]


def test_r5_plus_repeated_selonce_waits_for_the_next_data_without_select():
    tap = motor_on_p3("R7")
    tap.send("selonce 1")
    tap.run(300)
    assert len([line for _, line in tap.lines if line.startswith("P3M1:")]) == 1
    t = tap.send("selonce 1")
    tap.run(300)
    assert tap.dev(3, t) == []                      # same mode: no SELECT
    times = [tt for tt, line in tap.lines if line.startswith("P3M1:") and tt > t]
    data = [e["t"] for e in tap.devrx(3, t + 1)]
    assert len(times) == 1 and times[0] == data[0]  # reported as the next message arrives


def test_selrate_after_selonce_makes_it_periodic():
    tap = motor_on_p3("R7")
    tap.send("selonce 2 ; selrate 20")
    tap.run(300)
    times = [tt for tt, line in tap.lines if line.startswith("P3M2:")]
    assert len(times) > 10 and {b - a for a, b in zip(times, times[1:])} == {20}


def test_data_world_action_and_auto():
    tap = motor_on_p3("R7", extra={0: "0x3F"})
    tap.send("port 0 ; select 4")                   # FRAW, int16
    resting = first_report(tap, "P0M4:")
    tap.emu.world("@data 0 4 B2 02")                # 690: fully pressed (DEVICES.md)
    tap.run(150)
    assert first_report(tap, "P0M4:") == "P0M4: +690"
    tap.emu.world("@data 0 4 auto")
    tap.run(150)
    assert first_report(tap, "P0M4:") == resting
