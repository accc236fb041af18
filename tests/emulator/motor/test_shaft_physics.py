"""Motor physics (docs/EMULATOR-MODELS.md) and closed loops through the whole emulator.

The unit tests check the model's documented equations with hand-derived numbers; the loop
tests check behaviour a host relies on: the 2021 document's position PID moves a 0x30
motor one revolution each way every 3 s (R1-R4), the python-build-hat style position PID
converges on R6+, and a speed PID tracks its set point.
"""
from __future__ import annotations

import io
import random
import re

import pytest

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.emulator.devices.motor import MotorDevice
from buildhat_conformance.emulator.motor.shaft_physics import DEADBAND, TAU_S, MotorPhysics
from buildhat_conformance.emulator.script_mode import run_script
from buildhat_conformance.harness.transcript import read_transcript
from buildhat_conformance.protocol.devices import active_device
from buildhat_conformance.transcripts.script import parse_script

RATED_30 = 1110.0        # devices.json motion_model of 0x30


def motor(type_id: int = 0x30, seed: int = 3) -> MotorPhysics:
    return MotorPhysics(active_device(type_id), random.Random(seed))


# -- the model on its own -------------------------------------------------------------------

@pytest.mark.parametrize("duty", [255, 128, -200])
def test_steady_state_speed_is_rated_times_drive_minus_the_dead_band(duty):
    m = motor()
    m.step(2000, duty)
    # dw/dt = (rated*v - w)/tau - friction = 0  ->  w = rated * (v - sign * DEADBAND)
    v = duty / 255
    expected = RATED_30 * (v - DEADBAND * (1 if v > 0 else -1))
    assert m.speed_deg_s == pytest.approx(expected, rel=1e-6)
    assert m.speed_pct == round(100 * expected / RATED_30)


def test_first_order_rise():
    m = motor()
    m.step(50, 255)                  # one time constant: 1 - 1/e of the final speed (Euler, 1 ms)
    final = RATED_30 * (1 - DEADBAND)
    assert m.speed_deg_s == pytest.approx(final * (1 - 2.718281828 ** (-0.05 / TAU_S)), rel=0.02)


def test_sign_convention_positive_drive_counts_up():
    m = motor()
    apos0 = m.apos_deg
    m.step(300, 200)
    assert m.speed_pct > 0 and m.pos_deg > 0
    assert (m.apos_deg - apos0) % 360 == m.pos_deg % 360


def test_dead_band_keeps_a_resting_shaft_still():
    m = motor()
    m.step(1000, int(255 * DEADBAND) - 1)
    assert m.speed_deg_s == 0.0 and m.pos_deg == 0


def test_braking_at_zero_duty_and_coasting():
    braked, coasted = motor(), motor()
    for m in (braked, coasted):
        m.step(1000, 255)
    braked.step(60, 0)
    coasted.step(60, "coast")
    assert 0 <= braked.speed_deg_s < coasted.speed_deg_s
    coasted.step(2000, "coast")
    assert coasted.speed_deg_s == 0.0         # friction stops it and does not reverse it


def test_hold_stalls_and_pos_turns_the_shaft():
    m = motor()
    m.hold = True
    m.step(500, 255)
    assert m.speed_pct == 0 and m.pos_deg == 0
    m.hold = False
    apos0 = m.apos_deg
    m.set_position(-450)
    assert m.pos_deg == -450
    assert m.apos_deg == ((apos0 - 450 + 180) % 360) - 180
    m.reconnect()
    assert m.pos_deg == 0                     # POS restarts at a new connection, APOS does not


def test_apos_wraps_into_minus_180_179():
    m = motor()
    for _ in range(40):
        m.step(37, 255)
        assert -180 <= m.apos_deg <= 179


def test_speed_percent_is_clamped():
    m = motor()
    m.omega = 5000.0
    assert m.speed_pct == 100
    m.omega = -5000.0
    assert m.speed_pct == -100


def test_rated_speed_comes_from_the_catalogue():
    assert motor(0x41).rated == 660.0
    assert motor(0x30).rated == RATED_30


def test_bad_inputs_are_clear_errors():
    with pytest.raises(ValueError):
        MotorPhysics({"motion_model": {"rated_speed_deg_per_s": 0}})
    with pytest.raises(ValueError):
        motor().step(-1, 0)


# -- closed loops through the emulator ----------------------------------------------------------

COMBI = re.compile(r"^P0C0: +(-?\+?\d+) +(-?\+?\d+) +(-?\+?\d+)$")


def combi_samples(transcript):
    """(t, speed, pos, apos) from the P0C0 data lines a host would read."""
    out = []
    for e in transcript.of("hat"):
        m = COMBI.match(e.get("line", ""))
        if m:
            out.append((e["t"],) + tuple(int(g) for g in m.groups()))
    return out


DOC_SCRIPT = """\
@name the 2021 document's position PID example
@device 0 0x30
@device 1 none
@device 2 none
@device 3 none
> port 0
> plimit 1
> port 0 combi 0 1 0 2 0 3 0
> select 0
> plimit 1; bias .4
> pid 0 0 5 s2 0.0027777778 1 5 0 .1 3
> set square 0 1 3 0
@wait 9000
"""


@pytest.mark.req("FW-7.2")
@pytest.mark.parametrize("release", ["R1", "R4"])
def test_document_position_pid_turns_one_revolution_each_way_every_3_s(release):
    out = io.StringIO()
    assert run_script(parse_script(DOC_SCRIPT, "doc-position-pid.script"), out, firmware=release) == 0
    transcript = read_transcript(io.StringIO(out.getvalue()))
    samples = combi_samples(transcript)
    assert len(samples) >= 85                          # reported every 100 ms for 9 s

    def at(t):
        return [(p, a) for (ts, _, p, a) in samples if t - 50 <= ts <= t + 50]

    # The PV is APOS/360 unwrapped from 0, so the set point 0 is the absolute angle 0 and 1 is
    # one revolution further. Square 0..1 with T = 3 s: low in the first half of each period,
    # high (+360 degrees of POS, APOS back at 0) in the second half.
    base = at(1400)[0][0]
    for period in range(3):
        low_t, high_t = 3000 * period + 1400, 3000 * period + 2900
        for t, target in ((low_t, base), (high_t, base + 360)):
            got = at(t)
            assert got and all(abs(p - target) <= 6 and abs(a) <= 6 for p, a in got), (t, got)
    # the drive events show the motor driven both ways at full power
    duties = [e["value"] for e in transcript.of("pwm") if e["port"] == 0]
    assert 255 in duties and -255 in duties


def booted(release: str) -> Emulator:
    emu = Emulator(firmware=release, devices={0: "0x30", 1: "none", 2: "none", 3: "none"})
    emu.boot()
    emu.read()
    return emu


def motor_on_port_0(emu: Emulator) -> MotorDevice:
    assert emu.hat is not None
    device = emu.hat.ports[0].device
    assert isinstance(device, MotorDevice), device
    return device


@pytest.mark.parametrize("release", ["R6", "R7"])
def test_python_build_hat_style_position_pid_converges(release):
    emu = booted(release)
    shaft = motor_on_port_0(emu).physics
    # POS (s4 at offset 1 of combi 0) in revolutions, no unwrap; 11 numbers with a deadzone.
    emu.write(b"port 0 ; combi 0 1 0 2 0 3 0 ; select 0 ; selrate 10 ; plimit 1 ; "
              b"pid 0 0 1 s4 0.0027777778 0 5 0 .1 3 0.01 ; set 0.5\r")
    emu.advance(2500)
    assert abs(shaft.pos_deg - 180) <= 8
    emu.write(b"set -1.25\r")
    emu.advance(2500)
    assert abs(shaft.pos_deg + 450) <= 8


def test_speed_pid_tracks_its_set_point():
    emu = booted("R7")
    shaft = motor_on_port_0(emu).physics
    # PV = SPEED (percent, s1 at offset 0 of combi 0); PI control towards 40 %.
    emu.write(b"port 0 ; combi 0 1 0 2 0 3 0 ; select 0 ; selrate 10 ; plimit 1 ; "
              b"pid 0 0 0 s1 1 0 0.01 0.5 0 5 0 ; set 40\r")
    emu.advance(3000)
    assert abs(shaft.speed_pct - 40) <= 2
    emu.write(b"set -25\r")
    emu.advance(3000)
    assert abs(shaft.speed_pct + 25) <= 2


@pytest.mark.parametrize("release", ["R6", "R7"])
def test_pid_diff_speed_loop_on_pos_tracks_revolutions_per_second(release):
    emu = booted(release)
    shaft = motor_on_port_0(emu).physics
    # PV = d(POS/360) x 100 per 10 ms tick = revolutions per second; PI towards 1 rev/s.
    emu.write(b"port 0 ; combi 0 1 0 2 0 3 0 ; select 0 ; selrate 10 ; plimit 1 ; "
              b"pid_diff 0 0 1 s4 0.0027777778 0 0.2 1 0 1 0.01 ; set 1\r")
    emu.advance(3000)
    assert abs(shaft.speed_deg_s - 360) <= 20
    emu.write(b"set -0.5\r")
    emu.advance(3000)
    assert abs(shaft.speed_deg_s + 180) <= 20


def test_world_hold_and_pos_reach_the_shaft_and_the_data_lines():
    emu = booted("R7")
    emu.write(b"port 0 ; plimit 1 ; select 2 ; selrate 50\r")
    emu.world("@hold 0 1")
    emu.write(b"set 1\r")
    emu.advance(500)
    lines = emu.read().decode().split("\r\n")
    assert "P0M2:  0" in lines and not any(ln.startswith("P0M2: +") for ln in lines)
    emu.write(b"coast\r")
    emu.advance(20)                        # the coast reaches the driver on the next tick
    emu.world("@hold 0 0")
    emu.world("@pos 0 90")
    emu.advance(300)
    assert emu.read().decode().split("\r\n")[-2] == "P0M2: +90"
