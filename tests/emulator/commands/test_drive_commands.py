"""Drive commands through the whole emulator (FIRMWARE-FACTS §3 "Errors", §4.1, §4.2, §7, App. A)."""
from __future__ import annotations

import ctypes
import re
import struct

import pytest

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.emulator.motor.controller import MODE_PID, MODE_PID_DIFF, MODE_PWM

MOTOR_ON_P0 = {0: "0x30", 1: "none", 2: "none", 3: "none"}
EMPTY = {0: "none", 1: "none", 2: "none", 3: "none"}


def c_float(x: float) -> float:
    return ctypes.c_float(x).value


def booted(release: str, devices=None) -> Emulator:
    emu = Emulator(firmware=release, devices=devices or MOTOR_ON_P0)
    emu.boot()
    emu.read()
    return emu


def send(emu: Emulator, text: str) -> bytes:
    emu.write(text.encode() + b"\r")
    return emu.read()


# -- pid / pid_diff ------------------------------------------------------------------------

DOC_PID = "pid 0 0 5 s2 0.0027777778 1 5 0 .1 3"


@pytest.mark.req("FW-12.7")
@pytest.mark.parametrize("release", ["R6", "R7"])
def test_document_pid_on_r6_prints_error_and_leaves_pwm_mode_with_gains_stored(release):
    emu = booted(release)
    assert send(emu, DOC_PID) == b"\r\nError\r\n"
    c = emu.hat.controllers[0]
    assert c.pwmmode == MODE_PWM and not c.coast
    assert (c.pid.kp, c.pid.ki, c.pid.kd, c.pid.windup) == (5.0, 0.0, c_float(0.1), 3.0)
    assert (c.pv.port, c.pv.mode, c.pv.offset, c.pv.format) == (0, 0, 5, 0x102)
    assert c.pv.scale == c_float(0.0027777778) and c.pv.unwrap == 1.0
    assert send(emu, DOC_PID + " 0.01") == b"\r\n"
    assert c.pwmmode == MODE_PID and c.pid.deadzone == c_float(0.01)


@pytest.mark.parametrize("release", ["R1", "R4", "R5"])
def test_r1_r5_pid_takes_10_numbers_and_an_11th_is_applied_then_error(release):
    emu = booted(release)
    c = emu.hat.controllers[0]
    assert send(emu, DOC_PID) == b"\r\n"
    assert c.pwmmode == MODE_PID
    send(emu, "pwm")
    assert c.pwmmode == MODE_PWM
    assert send(emu, DOC_PID + " 0.01") == b"\r\nError\r\n"
    assert c.pwmmode == MODE_PID


def test_pid_failing_part_way_keeps_fields_forces_pwm_and_clears_coast():
    emu = booted("R7")
    c = emu.hat.controllers[0]
    send(emu, "pid 0 0 0 s1 1 0 1 0 0 1 0.01")
    send(emu, "coast")
    assert c.pwmmode == MODE_PID and c.coast
    assert send(emu, "pid 2 9 3 u2 0.5 x") == b"\r\nError\r\n"
    assert (c.pv.port, c.pv.mode, c.pv.offset, c.pv.format, c.pv.scale) == (2, 9, 3, 0x002, 0.5)
    assert c.pv.unwrap == 0.0                       # the failing field and later ones unchanged
    assert c.pwmmode == MODE_PWM and not c.coast


def test_svar_fields_are_clamped_and_scale_is_not():
    emu = booted("R7")
    c = emu.hat.controllers[0]
    send(emu, "pid 9 99 999 f4 1000 -7 1 2 3 4 5")
    assert (c.pv.port, c.pv.mode, c.pv.offset) == (3, 15, 127)
    assert (c.pv.scale, c.pv.unwrap) == (1000.0, -7.0)
    assert send(emu, "pid -1 0 0 s1 1 0 1 0 0 1 0") == b"\r\nError\r\n"    # unsigned port


def test_pid_diff_is_r6_only_and_sets_mode_2():
    emu = booted("R7")
    assert send(emu, "pid_diff 0 1 0 s1 1 0 1 0 0 1 0") == b"\r\n"
    assert emu.hat.controllers[0].pwmmode == MODE_PID_DIFF
    assert send(booted("R5"), "pid_diff 0 1 0 s1 1 0 1 0 0 1") == b"\r\nError\r\n"


def test_pid_does_not_reset_the_integrator():
    emu = booted("R7")
    c = emu.hat.controllers[0]
    c.pid.ie, c.pid.e_prev = 0.25, 0.5
    send(emu, "pid 0 4 0 f4 1 0 1 1 1 1 0")
    assert (c.pid.ie, c.pid.e_prev) == (0.25, 0.5)


# -- set ----------------------------------------------------------------------------------

def test_set_wave_parses_everything_first():
    emu = booted("R7")
    g = emu.hat.controllers[0].generator
    send(emu, "set triangle 0 1 2 0.5")
    before = (g.shape, g.a, g.b, g.period, g.phase)
    assert send(emu, "set t 0 1 1e3 0") == b"\r\nError\r\n"     # Appendix A
    assert send(emu, "set pulse 1 0 2") == b"\r\nError\r\n"     # the 4th number must be present
    assert (g.shape, g.a, g.b, g.period, g.phase) == before


def test_set_keywords_and_constants():
    emu = booted("R7")
    g = emu.hat.controllers[0].generator
    send(emu, "set si -1 1 0.001 7")
    assert (g.shape, g.period, g.phase) == ("sine", c_float(0.02), 1.0)
    send(emu, "set;0.25")
    assert (g.shape, g.a, g.b) == ("square", 0.25, 0.25)
    send(emu, "s p 1 0 1 0")
    assert g.shape == "pulse"
    assert send(emu, "set sine0 0 1 1 0") == b"\r\nError\r\n"
    assert send(emu, "set 0.5 0.3") == b"\r\nError\r\n" and g.a == 0.5


def test_set_var_is_r6_only_and_stores_the_map_before_the_svar():
    assert send(booted("R5"), "set v 0 1 1 0 0 1 0 s1 1 0") == b"\r\nError\r\n"
    emu = booted("R7")
    c = emu.hat.controllers[0]
    assert send(emu, "set var -1 1 0.01 0 0 1 0 s1") == b"\r\nError\r\n"
    g = c.generator
    assert (g.shape, g.vmin, g.vmax, g.slope, g.offset) == ("var", -1.0, 1.0, c_float(0.01), 0.0)
    assert (c.var.port, c.var.mode, c.var.offset, c.var.format) == (0, 1, 0, 0x101)


def test_set_var_follows_the_sensor():
    emu = booted("R7")
    c = emu.hat.controllers[0]
    send(emu, "set var -1 1 0.01 0 0 4 0 s2 1 0")
    emu.world("@data 0 4 32 00 00 00")               # 50 -> (50 - 0) * 0.01 = 0.5
    emu.advance(30)
    assert c.setpoint == c_float(c_float(50 * 1.0) * c_float(0.01))


# -- pwm / coast / on / off --------------------------------------------------------------

def test_on_off_keep_pid_mode_and_clear_coast():
    emu = booted("R1")
    c = emu.hat.controllers[0]
    send(emu, DOC_PID)
    send(emu, "coast")
    send(emu, "on")
    assert c.pwmmode == MODE_PID and not c.coast and c.generator.a == 1.0
    send(emu, "coast ; off")
    assert c.pwmmode == MODE_PID and not c.coast and c.generator.a == 0.0


def test_pwm_keeps_the_generator():
    emu = booted("R7")
    c = emu.hat.controllers[0]
    send(emu, "plimit 1 ; set 30 ; pwm")
    assert c.setpoint == 0.0 and c.generator.a == 30.0
    emu.advance(20)
    assert c.setpoint == 30.0 and c.duty == 255          # clamped to +1


def pwm_events(emu: Emulator, port: int = 0):
    return [e["value"] for e in emu.events if e["dir"] == "pwm" and e["port"] == port]


def test_driver_writes_only_on_change_and_coast():
    emu = booted("R7")
    start = len(pwm_events(emu))
    send(emu, "plimit 1 ; set 0.5")
    emu.advance(100)
    send(emu, "coast")
    emu.advance(100)
    send(emu, "set -1")
    emu.advance(100)
    assert pwm_events(emu)[start:] == [127, "coast", -255]


def test_default_limit_gives_25_and_minus_26():
    emu = booted("R7")
    send(emu, "set 1")
    emu.advance(20)
    assert emu.hat.controllers[0].duty == 25
    send(emu, "set -1")
    emu.advance(20)
    assert emu.hat.controllers[0].duty == -26


def test_empty_port_drives_zero():
    emu = booted("R7", EMPTY)
    send(emu, "port 3 ; plimit 1 ; set 1")
    emu.advance(50)
    assert emu.hat.controllers[3].duty == 0


# -- limits, bias, pwmparams ----------------------------------------------------------------

@pytest.mark.req("FW-7.3")
@pytest.mark.parametrize("release", ["R1", "R3", "R5"])
def test_global_plimit_survives_empty_port_resets(release):
    emu = booted(release, EMPTY)
    send(emu, "plimit 1")
    emu.advance(1000)                       # many empty-port resets
    assert [c.drive.limit for c in emu.hat.controllers] == [65536] * 4


@pytest.mark.req("FW-7.3")
@pytest.mark.parametrize("release", ["R6", "R7"])
def test_per_port_plimit_is_reset_to_0_1(release):
    emu = booted(release, {0: "0x30", 1: "none", 2: "none", 3: "none"})
    send(emu, "plimit 1")
    emu.advance(1000)
    limits = [c.drive.limit for c in emu.hat.controllers]
    assert limits[0] == 65536                # a connected device keeps it
    assert limits[1:] == [6554, 6554, 6554]  # empty ports were reset
    send(emu, "port 0 ; port_plimit 0.5")
    assert emu.hat.controllers[0].drive.limit == 32768


def test_bias_r1_r5_is_per_port_and_cleared_by_the_reset():
    emu = booted("R2", {0: "0x30", 1: "none", 2: "none", 3: "none"})
    send(emu, "bias .4 ; port 1 ; bias 2")
    ctl = emu.hat.controllers
    assert ctl[0].drive.bias == 26214
    emu.advance(500)                         # port 1 is empty: reset clears it
    assert ctl[1].drive.bias == 0 and ctl[0].drive.bias == 26214
    assert send(booted("R7"), "bias .4") == b"\r\nError\r\n"


def test_pwmparams_needs_both_numbers():
    emu = booted("R7")
    d = emu.hat.controllers[0].drive
    assert send(emu, "pwmparams 0.5") == b"\r\nError\r\n"
    assert (d.pwmthresh, d.minpwm) == (0, 0)
    send(emu, "pwmparams 0.5 2")
    assert (d.pwmthresh, d.minpwm) == (32768, 65536)


# -- waveform completion through the HAT -------------------------------------------------------

@pytest.mark.req("FW-7.1")
def test_pulse_done_timing_on_a_connected_port():
    emu = booted("R7")
    send(emu, "set pulse 1 0 1 0")
    t0 = emu.now
    got = []
    for _ in range(1100):
        emu.advance(1)
        out = emu.read()
        if b"pulse done" in out:
            got.append((emu.now - t0, out))
    # 101 ticks; the first is 1..10 ms after the command -> (1000, 1010] ms.
    assert len(got) == 1 and got[0][1] == b"P0: pulse done\r\n"
    assert 1000 < got[0][0] <= 1010


def test_pulse_on_an_empty_port():
    emu = booted("R7", EMPTY)
    # A 1 s pulse is wiped by the empty-port resets before it can end.
    send(emu, "port 3 ; set pulse 1 0 1 0")
    emu.advance(1500)
    assert b"done" not in emu.read()
    # A 20 ms one often survives (it reports whenever no reset falls inside it).
    out = b""
    for _ in range(15):
        send(emu, "set ramp 0 1 0.02 0")
        emu.advance(37)
        out += emu.read()
    lines = re.findall(rb"[^\r\n]+", out)
    assert lines and set(lines) == {b"P3: ramp done"}


# -- debug 16 through the whole HAT -----------------------------------------------------------

@pytest.mark.req("FW-7.4")
@pytest.mark.parametrize("release", ["R2", "R7"])
def test_debug16_example_through_device_data(release):
    emu = booted(release)
    ctl = emu.hat.controllers[0]
    pid = ("pid 0 4 0 f4 1 0 5 0.5 0.1 3 0.01" if emu.hat.profile.feature("pid_numbers") == 11
           else "pid 0 4 0 f4 1 0 5 0.5 0.1 3")
    assert send(emu, "port 0 ; plimit 1 ; set 1 ; " + pid + " ; debug 16") == b"\r\n"
    for pv in (0.0, 0.1, 0.25, 0.5, 0.995):
        while ctl.next_update_at != emu.now + 10:      # just after an update
            emu.advance(1)
        emu.world("@data 0 4 " + " ".join(f"{b:02x}" for b in struct.pack("<f", pv)))
        emu.advance(10)
    assert emu.read().decode().splitlines() == [
        "P0: pv=0.00000 sp=1.00000: e=-1.00000 ie=-0.0100000 de=-100.000 cv=15.0050",
        "P0: pv=0.100000 sp=1.00000: e=-0.900000 ie=-0.0190000 de=10.0000 cv=3.50950",
        "P0: pv=0.250000 sp=1.00000: e=-0.750000 ie=-0.0265000 de=15.0000 cv=2.26325",
        "P0: pv=0.500000 sp=1.00000: e=-0.500000 ie=-0.0315000 de=25.0000 cv=0.0157499",
        "P0: pv=0.995000 sp=1.00000: e=0.00000 ie=-0.0315000 de=50.0000 cv=-4.98425",
    ]
    # the last cv (-4.98) is clamped to -1 by the drive path: plimit 1 -> -255
    assert ctl.duty == -255


def test_pid_without_data_leaves_the_output_and_prints_no_debug_line():
    emu = booted("R7")
    ctl = emu.hat.controllers[0]
    send(emu, "port 0 ; plimit 1 ; set 0.5")
    emu.advance(30)
    assert ctl.duty == 127
    # mode 4 of the motor never sent data: every PID tick returns early (§7.2)
    assert send(emu, "pid 0 4 0 f4 1 0 5 0.5 0.1 3 0.01 ; debug 16") == b"\r\n"
    emu.advance(200)
    assert emu.read() == b"" and ctl.duty == 127 and ctl.pwmmode == MODE_PID
    assert (ctl.pid.ie, ctl.pid.e_prev) == (0.0, 0.0)


def test_coast_wins_over_pid_and_debug_is_silent():
    emu = booted("R7")
    ctl = emu.hat.controllers[0]
    send(emu, "port 0 ; plimit 1 ; pid 0 4 0 f4 1 0 5 0 0 3 0.01 ; set 1 ; debug 16 ; coast")
    emu.world("@data 0 4 00 00 00 00")
    emu.advance(100)
    assert emu.read() == b"" and ctl.duty == "coast"
    send(emu, "on")                         # clears coast; PID resumes and prints
    emu.advance(30)
    assert emu.read().startswith(b"P0: pv=0.00000 sp=1.00000: e=-1.00000")


# -- the port reset (§4.2) seen through the controller ------------------------------------------

@pytest.mark.req("FW-4.2")
@pytest.mark.parametrize("release,kept", [("R5", 65536), ("R7", 6554)])
def test_plimit_before_plugging_a_motor(release, kept):
    emu = booted(release, EMPTY)
    send(emu, "plimit 1")
    emu.advance(110)        # one empty-port cycle (98 ms): the port passes its reset before the plug
    emu.world("@plug 0 0x30")
    for _ in range(5000):
        emu.advance(10)
        if emu.hat.ports[0].established:
            break
    assert emu.hat.ports[0].established
    assert emu.hat.controllers[0].drive.limit == kept      # lost on R6+ (§7.3)


@pytest.mark.req("FW-4.2")
@pytest.mark.parametrize("release,wiped", [("R1", True), ("R2", False)])
def test_r1_resets_a_passive_port_every_scan(release, wiped):
    emu = booted(release, {0: "none", 1: "none", 2: "passive 8", 3: "none"})
    send(emu, "port 2 ; set 0.5")
    emu.advance(400)
    assert (emu.hat.controllers[2].generator.a == 0.0) is wiped


@pytest.mark.parametrize("release,powered", [("R1", False), ("R3", False), ("R4", True),
                                             ("R5", False), ("R6", True), ("R7", True)])
def test_led_matrix_auto_power_per_release(release, powered):
    emu = booted(release, {0: "none", 1: "0x40", 2: "none", 3: "none"})
    ctl = emu.hat.controllers[1]
    emu.advance(20)
    assert (ctl.generator.a == 1.0) is powered
    # the limit still applies: 0.1 -> duty 25
    assert ctl.duty == (25 if powered else 0)


def test_controller_updates_every_10_ms_without_drift():
    emu = booted("R7")
    # T = 0.02 s: 0.01f / 0.02f is exactly 0.5 -> b, then the accumulator wraps to 0 -> a.
    send(emu, "plimit 1 ; set square -1 1 0.02 0")
    emu.advance(1000)
    events = [e for e in emu.events if e["dir"] == "pwm" and e["port"] == 0][-90:]
    times = [e["t"] for e in events]
    assert [b - a for a, b in zip(times, times[1:])] == [10] * 89
    values = [e["value"] for e in events]
    assert set(values) == {255, -255} and all(a != b for a, b in zip(values, values[1:]))


def test_process_variable_from_another_port():
    emu = booted("R7", {0: "0x30", 1: "0x30", 2: "none", 3: "none"})
    # port 0's PID reads mode 4 of the device on port 1 (f4 2.5): e = 2.5 - 0 = 2.5
    send(emu, "port 0 ; pid 1 4 0 f4 1 0 1 0 0 1 0.01 ; set 0 ; debug 16")
    emu.world("@data 1 4 00 00 20 40")
    emu.advance(30)
    lines = emu.read().decode().split("\r\n")
    assert "P0: pv=2.50000 sp=0.00000: e=2.50000 ie=0.0250000 de=250.000 cv=-2.50000" in lines


@pytest.mark.parametrize("beyond,last", [("9 3 0 s2", "3 3 0 s2"), ("0 20 0 s2", "0 15 0 s2"),
                                        ("0 2 128 u1", "0 2 127 u1")])
def test_a_sensor_variable_past_the_last_reads_the_last(beyond, last):
    # FIRMWARE-BEHAVIOUR.md#fb-svar-clamp: "`pid 4 …` does exactly what `pid 3 …` does, and likewise
    # for the mode and the offset"; on the wire, the same `debug 16` lines.
    def lines(svar: str) -> list:
        emu = booted("R7", {0: "0x30", 1: "none", 2: "none", 3: "0x30"})
        emu.world("@data 3 3 2C 01")
        emu.world("@data 0 3 2C 01")
        send(emu, "port 3 ; select 3 ; port 0 ; select 3")
        emu.advance(50)
        send(emu, "select 2")
        emu.advance(50)
        emu.read()
        port = svar.split()[0]
        send(emu, f"port {'3' if port in ('3', '9') else '0'} ; pid {svar} 1 0 0 0 0 0 0 ; debug 16")
        emu.advance(100)
        return [ln for ln in emu.read().decode().splitlines() if ": pv=" in ln]

    assert lines(beyond) == lines(last)
    if beyond.startswith("9"):                    # port 3's motor reports APOS 300
        assert lines(beyond) and all("pv=300.000" in ln for ln in lines(beyond)), lines(beyond)
