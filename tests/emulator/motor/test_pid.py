"""PID and process-variable maths (FIRMWARE-FACTS §7.2, §7.4) against the facts' own numbers."""
from __future__ import annotations

import ctypes
import math
import struct

import pytest

from buildhat_conformance.emulator.hat import Hat
from buildhat_conformance.emulator.motor.pid import NO_SAMPLE, Pid, SensorVariable, decode_value
from buildhat_conformance.protocol.profiles import get_profile


def c_float(x: float) -> float:
    return ctypes.c_float(x).value


# §7.4, verbatim: Kp=5, Ki=0.5, Kd=0.1, windup=3, deadzone 0.01, SP = 1, PV = 0 .. 0.995.
EXAMPLE_PVS = [0.0, 0.1, 0.25, 0.5, 0.995]
EXAMPLE_LINES = """\
P0: pv=0.00000 sp=1.00000: e=-1.00000 ie=-0.0100000 de=-100.000 cv=15.0050
P0: pv=0.100000 sp=1.00000: e=-0.900000 ie=-0.0190000 de=10.0000 cv=3.50950
P0: pv=0.250000 sp=1.00000: e=-0.750000 ie=-0.0265000 de=15.0000 cv=2.26325
P0: pv=0.500000 sp=1.00000: e=-0.500000 ie=-0.0315000 de=25.0000 cv=0.0157499
P0: pv=0.995000 sp=1.00000: e=0.00000 ie=-0.0315000 de=50.0000 cv=-4.98425""".splitlines()


@pytest.mark.req("FW-7.4")
@pytest.mark.parametrize("release", ["R1", "R5", "R7"])
def test_debug16_example_sequence_is_byte_exact(release):
    hat = Hat(get_profile(release))
    ctl = hat.controllers[0]
    pid = ctl.pid
    pid.kp, pid.ki, pid.kd, pid.windup, pid.deadzone = 5.0, 0.5, c_float(0.1), 3.0, c_float(0.01)
    lines = [ctl.debug_line(pid.step(c_float(pv), 1.0)) for pv in EXAMPLE_PVS]
    assert lines == EXAMPLE_LINES


def test_output_sign_and_windup_clamp():
    pid = Pid("parameter")
    pid.kp, pid.ki, pid.windup = 1.0, 1.0, 0.02
    step = pid.step(2.0, 1.0)            # PV above SP -> negative drive
    assert step.e == 1.0 and step.cv < 0
    for _ in range(10):
        step = pid.step(2.0, 1.0)
    assert step.ie == 0.02               # clamped to +windup
    for _ in range(10):
        step = pid.step(-5.0, 1.0)
    assert step.ie == -0.02


def test_fixed_deadzone_r1_r5_versus_parameter_r6():
    fixed = Pid("fixed")
    param = Pid("parameter")
    param.deadzone = 0.0
    for pv in (1.009, 0.9915):
        e = c_float(c_float(pv) - 1.0)
        assert abs(e) < 0.01
        assert fixed.step(c_float(pv), 1.0).e == 0.0
        assert param.step(c_float(pv), 1.0).e == e
    assert fixed.step(c_float(1.02), 1.0).e == c_float(c_float(1.02) - 1.0)
    param.deadzone = 0.5
    assert param.step(1.4, 1.0).e == 0.0


def test_derivative_acts_on_the_error_divided_in_double():
    pid = Pid("parameter")
    pid.kd = 1.0
    assert pid.step(0.0, 0.0).de == 0.0
    step = pid.step(0.0, 0.3)            # a set-point step kicks the derivative
    assert step.de == c_float(c_float(-c_float(0.3)) / 0.01)
    assert step.cv == -step.de


def test_nan_flows_through_the_pid():
    pid = Pid("parameter")
    pid.kp, pid.windup = 1.0, 1.0
    step = pid.step(float("nan"), 0.0)
    assert step.cv != step.cv              # NaN: the drive path must cope (drive.py)


# -- process variable ------------------------------------------------------------------------

@pytest.mark.parametrize("code,payload,expected", [
    (0x001, b"\xff", 255.0), (0x101, b"\xff", -1.0),
    (0x002, b"\x00\x80", 32768.0), (0x102, b"\x4c\xff", -180.0),
    (0x004, b"\xff\xff\xff\xff", c_float(4294967295.0)), (0x104, b"\x00\x00\x00\x80", -2147483648.0),
    (0x204, struct.pack("<f", 1.5), 1.5),
])
def test_decode_formats(code, payload, expected):
    assert decode_value(b"\x07" + payload, 1, code) == expected


def test_decode_past_the_payload_reads_zero():
    assert decode_value(b"\x05", 0, 0x104) == 5.0


def _svar(rule: str, scale: float = 1.0, unwrap: float = 0.0) -> SensorVariable:
    sv = SensorVariable(rule)
    sv.format, sv.scale, sv.unwrap = 0x102, scale, unwrap
    return sv


def s2(v: int) -> bytes:
    return struct.pack("<h", v)


def test_unwrap_r1_r5_starts_from_zero_and_persists():
    sv = _svar("zero_persistent", unwrap=360.0)
    # First sample 270 with last = 0: d = 270 > 180 -> folded once to -90.
    assert sv.sample(s2(270)) == -90.0
    assert sv.sample(s2(-170)) == -170.0                 # d = -440 -> folded to -80
    sv.restart()                                          # `pid` does not reset it (R1-R5)
    assert sv.sample(s2(-160)) == -160.0
    assert sv.sample(s2(170)) == -190.0                  # -160 -> 170 is -30 across the wrap
    sv.clear()                                            # only the port reset does
    assert (sv.value, sv.last, sv.scale, sv.unwrap) == (0.0, 0.0, 0.0, 0.0)
    sv.format, sv.scale, sv.unwrap = 0x102, 1.0, 360.0
    assert sv.sample(s2(100)) == 100.0


def test_unwrap_r6_takes_the_first_sample_after_each_pid():
    sv = _svar("first_sample", unwrap=360.0)
    assert sv.last == NO_SAMPLE
    assert sv.sample(s2(270)) == 270.0
    assert sv.sample(s2(-170)) == 190.0                  # d = -440 -> folded to -80
    sv.restart()
    assert sv.sample(s2(10)) == 10.0


def test_scale_is_applied_and_never_clamped():
    sv = _svar("first_sample", scale=1000.0)
    assert sv.sample(s2(100)) == 100000.0


def test_pid_diff_is_x100_per_tick_and_zero_without_new_data():
    sv = _svar("first_sample")
    assert sv.sample(s2(50), differentiate=True) == 0.0      # first sample gives 0
    assert sv.sample(s2(53), differentiate=True) == 300.0
    assert sv.sample(s2(53), differentiate=True) == 0.0
    wrapped = _svar("first_sample", unwrap=360.0)
    wrapped.sample(s2(179), differentiate=True)
    assert wrapped.sample(s2(-179), differentiate=True) == 200.0   # +2 degrees across the wrap


def test_no_data_leaves_the_state_alone():
    sv = _svar("zero_persistent")
    assert sv.sample(None) is None and sv.value == 0.0


def test_bad_profile_values_are_clear_errors():
    with pytest.raises(ValueError, match="unwrap_init"):
        SensorVariable("sometimes")
    with pytest.raises(ValueError, match="pid_deadzone"):
        Pid("wide")


def test_nan_signs_follow_the_firmware_in_the_loop():
    # Issue 37: with e=Inf, ie=NaN (positive) and de=-NaN the firmware in the loop prints cv=-NaN
    # (transcripts/data/timing/pid-nan.script), and with e=-NaN, ie=NaN, de=-NaN also cv=-NaN: of two
    # NaNs a sum keeps the left one's, the integral term added to the proportional one.
    nan, inf = float("nan"), float("inf")
    pid = Pid("parameter")
    pid.kp = pid.ki = pid.kd = pid.windup = 1.0
    pid.ie, pid.e_prev = nan, inf                 # a NaN integrator (its clamps compare false)
    step = pid.step(inf, 0.0)           # e = Inf, de = (Inf - Inf) / 0.01 = -NaN (x86's default NaN)
    assert math.isnan(step.cv) and math.copysign(1.0, step.cv) < 0
    pid.e_prev = -inf
    step = pid.step(math.copysign(nan, -1.0), 0.0)     # e = -NaN, de = -NaN
    assert math.isnan(step.cv) and math.copysign(1.0, step.cv) < 0
