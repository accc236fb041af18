"""PWM drive path (FIRMWARE-FACTS §7.3): Q16, bias, slow PWM, limit, duty, with hand-derived numbers."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from buildhat_conformance.emulator.motor.pwm_drive import DrivePath, duty_from_q16, param_q16, to_q16


@pytest.mark.req("FW-7.3")
@pytest.mark.parametrize("x,q16", [
    (1.0, 65536), (-1.0, -65535), (0.0, 0), (5.0, 65536), (-30.0, -65535),
    # 0.1 (as parsed, float32 0.100000001): trunc(13107.2) = 13107; (13107 + 1) / 2 = 6554
    (0.10000000149011612, 6554),
    # -0.1: trunc = -13107; (-13107 + 1) / 2 = -6553 (C division truncates toward 0)
    (-0.10000000149011612, -6553),
    # 0.5 -> 65536 + 1 = 65537 / 2 = 32768
    (0.5, 32768),
    # tiny values: trunc(1e-6 * 131072) = 0 -> (0 + 1) / 2 = 0
    (1e-6, 0), (-1e-5, 0),
    # -1/131072: trunc = -1 -> (-1 + 1) / 2 = 0; -2/131072: -2 + 1 = -1 -> -1 / 2 = 0
    (-2.0 / 131072, 0), (-3.0 / 131072, -1),
])
def test_q16_conversion(x, q16):
    assert to_q16(x) == q16


def test_nan_reaches_the_driver_as_zero():
    assert to_q16(float("nan")) == 0


@pytest.mark.req("FW-7.3")
@pytest.mark.parametrize("q16,duty", [
    (65536, 255),            # (65536*255 + 127) >> 16 = 255
    (-65535, -255),          # (-16711425 + 127) >> 16 = floor(-254.998) = -255
    (6554, 25),              # 1671397 >> 16 = 25
    (-6553, -26),            # -1670888 >> 16 = floor(-25.496) = -26
    (0, 0), (256, 0), (257, 1), (-1, -1),
])
def test_duty_is_a_flooring_shift(q16, duty):
    assert duty_from_q16(q16) == duty


def test_facts_examples_end_to_end_with_no_limit():
    d = DrivePath(biased=False)
    d.limit = 65536
    assert d.drive(1.0) == 255
    assert d.drive(-0.10000000149011612) == -26
    assert d.drive(0.10000000149011612) == 25


def test_default_limit_is_0_1():
    d = DrivePath(biased=True)
    assert d.limit == 6554
    assert d.drive(1.0) == 25 and d.drive(-1.0) == -26


@pytest.mark.parametrize("x,q16", [(0.0, 0), (1.0, 65536), (2.0, 65536), (-0.5, 0),
                                   (0.4000000059604645, 26214), (0.1, 6554)])
def test_parameter_q16(x, q16):
    # floor(x * 65536 + 0.5): 0.4 -> 26214.4 -> 26214; 0.1 -> 6553.6 -> 6554
    assert param_q16(x) == q16


def test_bias_r1_r5_moves_non_zero_values_away_from_zero():
    d = DrivePath(biased=True)
    d.limit, d.bias = 65536, 26214                       # plimit 1 ; bias .4
    assert d.drive(0.0) == 0                             # 0 stays 0
    assert d.drive(0.1) == duty_from_q16(6554 + 26214)   # 32768 -> 127
    assert d.drive(0.1) == 127
    assert d.drive(-0.1) == duty_from_q16(-6553 - 26214)
    assert d.drive(1.0) == 255                           # 65536 + bias is clamped by the limit


def test_r6_minpwm_and_slow_pwm():
    d = DrivePath(biased=False)
    d.limit = 65536
    d.minpwm = 6554                       # |u| < 0.1 -> 0
    assert d.drive(0.05) == 0
    d.minpwm = 0
    d.pwmthresh = 32768                   # below 0.5: accumulate and pulse at +-0.5
    # u = 0.2 -> 13107 per tick: acc 13107, 26214, 39321 -> pulse 32768, acc 6553 ...
    # duty of 32768: (8355840 + 127) >> 16 = 127; of -32768: floor(-127.498) = -128
    duties = [d.drive(0.2) for _ in range(5)]
    assert duties == [0, 0, 127, 0, 0]
    # negative values pulse at -thresh
    d.slow_acc = 0
    assert [d.drive(-0.3) for _ in range(4)] == [0, -128, 0, -128]
    # above the threshold: straight through
    assert d.drive(0.75) == duty_from_q16(to_q16(0.75))


def test_reset_keeps_or_restores_the_limit():
    d = DrivePath(biased=False)
    d.limit, d.pwmthresh, d.minpwm = 65536, 100, 200
    d.reset(reset_limit=False)
    assert (d.limit, d.pwmthresh, d.minpwm) == (65536, 0, 0)
    d.reset(reset_limit=True)
    assert d.limit == 6554


@settings(max_examples=100, deadline=None)
@given(x=st.floats(-3, 3, width=32))
def test_q16_and_duty_against_the_formula(x):
    clamped = max(-1.0, min(1.0, x))
    t = math.trunc(clamped * 131072) + 1
    expected = int(t / 2)                       # C division: toward zero
    assert to_q16(x) == expected
    assert duty_from_q16(expected) == math.floor((expected * 255 + 127) / 65536)
    assert -255 <= duty_from_q16(expected) <= 255


@settings(max_examples=100, deadline=None)
@given(x=st.floats(-1, 1, width=32), limit=st.floats(0, 1, width=32))
def test_the_limit_bounds_the_duty(x, limit):
    d = DrivePath(biased=False)
    d.limit = param_q16(limit)
    duty = d.drive(x)
    assert abs(duty) <= duty_from_q16(d.limit) + 1
    assert (duty > 0) <= (x > 0)                # never drives against the sign of x
