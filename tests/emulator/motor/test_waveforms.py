"""Set-point generator (FIRMWARE-FACTS §7.1) against the facts' numbers and an independent oracle.

The oracle below re-derives each sample from the §7.1 text with ctypes' float32 (not with
emulator/f32.py), so a slip in either shows up as a mismatch.
"""
from __future__ import annotations

import ctypes
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from buildhat_conformance.emulator.motor.waveforms import SINE_TABLE, SetpointGenerator


def c_float(x: float) -> float:
    return ctypes.c_float(x).value


# §7.1: "the end occurs after N ticks" for these periods.
TICK_TABLE = [(0.1, 11), (0.2, 20), (0.5, 51), (1, 101), (2, 201), (3, 301), (5, 500), (10, 1000),
              (0.3, 30), (0.7, 71)]


def ticks_until_done(gen: SetpointGenerator, limit: int = 5000):
    for n in range(1, limit + 1):
        value, done = gen.step()
        if done:
            return n, value, done
    raise AssertionError("no pulse/ramp end within the limit")


@pytest.mark.req("FW-7.1")
@pytest.mark.parametrize("period,ticks", TICK_TABLE)
@pytest.mark.parametrize("shape", ["pulse", "ramp"])
def test_pulse_and_ramp_end_after_the_tick_counts_of_the_facts(shape, period, ticks):
    gen = SetpointGenerator()
    gen.set_wave(shape, 0.75, -0.5, c_float(period), 0.0)
    n, value, done = ticks_until_done(gen)
    assert n == ticks
    assert done == f"{shape} done"
    assert value == -0.5            # the end tick already drives the second parameter


def test_end_is_reported_once_and_the_value_stays_at_the_second_parameter():
    gen = SetpointGenerator()
    gen.set_wave("pulse", 1.0, 0.25, 0.1, 0.0)
    events = [gen.step() for _ in range(500)]
    assert [i for i, (_, d) in enumerate(events) if d] == [10]
    assert all(v == 1.0 for v, _ in events[:10])
    assert all(v == 0.25 for v, _ in events[10:])


def _oracle(shape: str, a: float, b: float, period: float, phase: float, ticks: int):
    """§7.1 in prose, re-derived: u = float(acc + 0.01) in double; wrap; x = u/T + phase."""
    a, b, period, phase = c_float(a), c_float(b), c_float(period), c_float(phase)
    period = min(max(period, 0.02), 1e30)
    phase = min(max(phase, 0.0), 1.0)
    table = [c_float(round(math.sin(2 * math.pi * k / 256), 5)) for k in range(256)]
    acc = 0.0
    out = []
    for _ in range(ticks):
        u = c_float(acc + 0.01)
        if u >= period:
            u = c_float(u - period)
            if u >= period:
                u = 0.0
        acc = u
        x = c_float(c_float(u / period) + phase)
        if x >= 1.0:
            x = c_float(x - 1.0)
        span = c_float(b - a)
        if shape == "square":
            out.append(b if x >= 0.5 else a)
        elif shape == "sine":
            i = int(c_float(c_float(x * 256) + 0.5)) % 256
            out.append(c_float(a + c_float(c_float(span * c_float(table[i] + 1)) * 0.5)))
        elif shape == "triangle":
            if x >= 0.5:
                x = c_float(1 - x)
            out.append(c_float(a + c_float(span * c_float(x * 2))))
        elif shape == "ramp":
            out.append(c_float(a + c_float(span * x)))
    return out


@pytest.mark.req("FW-7.1")
@pytest.mark.parametrize("shape,a,b,period,phase", [
    ("square", -1.0, 1.0, 0.37, 0.0),
    ("square", 0.0, 1.0, 3.0, 0.25),
    ("sine", -0.5, 0.8, 0.64, 0.0),
    ("sine", 0.0, 1.0, 1.0, 0.7),
    ("triangle", 0.0, 1.0, 10.0, 0.0),
    ("triangle", -2.0, 3.0, 0.45, 0.9),
])
def test_periodic_waveforms_match_the_oracle(shape, a, b, period, phase):
    gen = SetpointGenerator()
    gen.set_wave(shape, a, b, period, phase)
    got = [gen.step()[0] for _ in range(1200)]
    assert got == _oracle(shape, a, b, period, phase, 1200)


def test_ramp_with_phase_matches_the_oracle_until_its_end():
    gen = SetpointGenerator()
    gen.set_wave("ramp", 0.0, 1.0, 1.0, 0.5)
    got = [gen.step()[0] for _ in range(100)]
    assert got == _oracle("ramp", 0.0, 1.0, 1.0, 0.5, 100)
    # Phase is not ignored for ramp: it starts half-way and wraps back to the start value.
    assert 0.5 < got[0] < 0.52
    assert any(v < 0.05 for v in got[50:])


def test_hand_derived_samples():
    # sine 0..1 with T = 1: tick 25 -> x = 0.25 -> table[64] = 1 -> exactly b; tick 75 -> a.
    gen = SetpointGenerator()
    gen.set_wave("sine", 0.0, 1.0, 1.0, 0.0)
    values = [gen.step()[0] for _ in range(100)]
    assert values[24] == 1.0 and values[74] == 0.0
    # The table starts mid-way and rising: sin(0) = 0 -> (0 + 1) * 0.5.
    assert SINE_TABLE[0] == 0.0 and SINE_TABLE[64] == 1.0 and SINE_TABLE[192] == -1.0
    assert SINE_TABLE[1] == c_float(0.02454)
    # square with phase 0 starts at a.
    gen.set_wave("square", 3.0, 4.0, 1.0, 0.0)
    assert gen.step()[0] == 3.0
    # pulse: the first parameter for the whole period, phase or not.
    gen.set_wave("pulse", 0.5, 0.0, 1.0, 0.9)
    assert {gen.step()[0] for _ in range(100)} == {c_float(0.5)}


def test_clamps_of_period_and_phase():
    # Appendix A: `set si -1 1 0.001 7` -> sine, T = 0.02, phase = 1.
    gen = SetpointGenerator()
    gen.set_wave("sine", -1.0, 1.0, c_float(0.001), 7.0)
    assert (gen.shape, gen.period, gen.phase) == ("sine", c_float(0.02), 1.0)
    gen.set_wave("square", 0.0, 1.0, 1e38, -3.0)
    assert gen.period == c_float(1e30) and gen.phase == 0.0
    # min and max are not clamped
    gen.set_wave("triangle", -50.0, 50.0, 1.0, 0.0)
    assert (gen.a, gen.b) == (-50.0, 50.0)


def test_constant_keeps_the_accumulator_and_waves_reset_it():
    gen = SetpointGenerator()
    gen.set_wave("square", 0.0, 1.0, 1.0, 0.0)
    for _ in range(30):
        gen.step()
    acc = gen.acc
    assert acc > 0.29
    gen.set_constant(0.5)
    assert gen.acc == acc and gen.period == 1.0 and gen.step()[0] == 0.5
    gen.set_wave("triangle", 0.0, 1.0, 1.0, 0.0)
    assert gen.acc == 0.0


def test_var_shape_maps_and_clamps_the_sensor_value():
    gen = SetpointGenerator()
    gen.set_var_map(-1.0, 1.0, 0.5, 10.0)       # clamp((v - 10) * 0.5, -1, 1)
    assert gen.step(lambda: 11.0)[0] == 0.5
    assert gen.step(lambda: 100.0)[0] == 1.0
    assert gen.step(lambda: -100.0)[0] == -1.0


def test_unknown_shape_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown waveform"):
        SetpointGenerator().set_wave("sawtooth", 0, 1, 1, 0)


@settings(max_examples=60, deadline=None)
@given(period=st.floats(0.02, 3.0), a=st.floats(-5, 5), b=st.floats(-5, 5))
def test_any_pulse_ends_once_near_its_period(period, a, b):
    period, a, b = c_float(period), c_float(a), c_float(b)
    gen = SetpointGenerator()
    gen.set_wave("pulse", a, b, period, 0.0)
    ticks = int(3 * period / 0.01) + 5
    events = [gen.step() for _ in range(ticks)]
    ends = [i + 1 for i, (_, d) in enumerate(events) if d]
    assert len(ends) == 1 and ends[0] <= period / 0.01 + 1.5 and ends[0] >= period / 0.01 - 0.5
    n = ends[0]
    assert all(v == a for v, _ in events[:n - 1]) and all(v == b for v, _ in events[n - 1:])
