"""Motor drive as a motor shows it: direct PWM, plimit, bias, coast, per-port controllers.

The drive level is not printed, so these checks read the motor's own SPEED (mode 1, percent
of rated speed, devices.json) and compare orders of magnitude only: the document gives no
motor model, and a real motor's speed depends on load and supply.
"""
from __future__ import annotations

import re
from typing import Optional

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import rejected
from ..needs import PortNeeds
from ..probes import data_lines, pid_lines, reports_after, start_quiet_pid
from ..verdict import Verdict


def speed(hat: HatUnderTest, port: int, settle_ms: float = 700) -> float:
    """The motor's mean SPEED over a few reports, after ``settle_ms`` of HAT time."""
    hat.exchange(f"port {port} ; select 1")
    hat.wait_ms(settle_ms)
    hat.collect_ms(0)
    lines = data_lines(hat.wait_for(lambda e: e.text.startswith(f"P{port}M1:"), 4, 1500), port)
    values = [int(m.group(1).replace(" ", "")) for m in
              (re.fullmatch(rf"P{port}M1: ?( 0|[+-][0-9]+)", ln) for ln in lines) if m]
    assert values, f"no SPEED reports from the motor on port {port}"
    return sum(values[-4:]) / len(values[-4:])


def drive(hat: HatUnderTest, port: int, line: str) -> None:
    reply = hat.exchange(f"port {port} ; {line}")
    assert reply.errors == 0, f"`{line}`: {reply.raw!r}"


@pytest.mark.req("CMD-SET-CONST", "CMD-SET-PWM-RANGE", "CMD-PWM")
def test_setpoint_sign_and_size_drive_the_motor(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    drive(hat, p, "pwm ; plimit 1 ; set 0.6")
    forward = speed(hat, p)
    drive(hat, p, "set -0.6")
    backward = speed(hat, p)
    drive(hat, p, "set 0")
    stopped = speed(hat, p, settle_ms=1200)
    hat.exchange("plimit 0.1")
    assert forward > 10 and backward < -10, f"set 0.6 -> SPEED {forward}, set -0.6 -> {backward}"
    assert abs(stopped) < 0.5 * min(abs(forward), abs(backward)), f"set 0 -> SPEED {stopped}"


@pytest.mark.req("CMD-PLIMIT", "SYN-PLIMIT-FIRST")
def test_plimit_default_after_a_reset_is_a_tenth(hat: HatUnderTest, world: PortNeeds,
                                                 motor_port: int) -> None:
    world.require("reset", "resetting the HAT (its reset line)")
    mark = hat.mark()
    world.action("@reset")
    # Input is thrown away while the firmware starts (docs/FIRMWARE-BEHAVIOUR.md#fb-boot-input): wait
    # for the banner's end.
    hat.expect(lambda e: e.text == "Done initialising ports" and e in hat.since(mark), 8000)
    hat.expect(lambda e: e.text.startswith(f"P{motor_port}: established") and e in hat.since(mark), 8000)
    p = world.active(0x30)
    hat.powered_ports = ()
    drive(hat, p, "set 1")
    limited = speed(hat, p)
    drive(hat, p, "plimit 1")
    full = speed(hat, p)
    drive(hat, p, "set 0 ; plimit 0.1")
    # Document: "the default value is 0.1; this will usually need to be increased".
    assert full > 30 and abs(limited) < 0.5 * full, f"after reset: SPEED {limited}; after plimit 1: {full}"


@pytest.mark.req("CMD-PLIMIT", "SYN-PLIMIT-FIRST")
def test_plimit_limits_the_drive(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    drive(hat, p, "pwm ; plimit 0.1 ; set 1")
    limited = speed(hat, p)
    drive(hat, p, "plimit 1")
    full = speed(hat, p)
    drive(hat, p, "plimit 0.1 ; set 0")
    assert full > 30 and abs(limited) < 0.5 * full, f"plimit 0.1: SPEED {limited}; plimit 1: {full}"


@pytest.mark.req("CMD-PLIMIT")
def test_plimit_before_plugging_the_motor(hat: HatUnderTest, world: PortNeeds, verdict: Verdict,
                                          empty_port: int) -> None:
    world.require("plug", "plugging a motor in after plimit")
    p = empty_port
    hat.exchange("plimit 1")
    # An empty port is reset about every 100 ms (docs/FIRMWARE-BEHAVIOUR.md#fb-port-reset): wait for
    # a few of those first.
    hat.wait_ms(400)
    world.plug(p, ("active", 0x30))
    drive(hat, p, "set 1")
    full = speed(hat, p)
    drive(hat, p, "set 0 ; plimit 0.1")
    # Document: a global limit, so 1 still applies. R6+: reset to 0.1 with the port
    # (docs/FIRMWARE-BEHAVIOUR.md#fb-doc-plimit).
    verdict.document(full > 30, key="PLIMIT-RESET-ON-EMPTY-PORT", firmware_ok=0 < full <= 30,
                     seen=f"SPEED {full} after plimit 1 then plug then set 1")


@pytest.mark.req("CMD-BIAS")
def test_bias_adds_to_the_drive(hat: HatUnderTest, verdict: Verdict, motor_port: int) -> None:
    p = motor_port
    drive(hat, p, "pwm ; plimit 1 ; set 0.05")
    plain = speed(hat, p)
    reply = hat.exchange("bias 0.4")
    biased: Optional[float] = speed(hat, p) if reply.errors == 0 else None
    hat.exchange("set 0 ; plimit 0.1")
    if hat.has("bias"):
        hat.exchange("bias 0")
    ok = biased is not None and biased > plain + 15
    verdict.document(ok, key="BIAS-REMOVED", firmware_ok=reply.raw == b"\r\nError\r\n",
                     seen=f"set 0.05: SPEED {plain}; after `bias 0.4` ({reply.raw!r}): {biased}")


@pytest.mark.req("CMD-COAST")
def test_coast_lets_the_motor_run_down(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    drive(hat, p, "pwm ; plimit 1 ; set 0.8")
    running = speed(hat, p)
    drive(hat, p, "coast")
    coasting = speed(hat, p, settle_ms=2500)
    hat.exchange("set 0 ; plimit 0.1")
    assert running > 30 and abs(coasting) < 0.25 * running, f"running {running}, after coast {coasting}"


@pytest.mark.req("CTL-PER-PORT")
def test_each_port_has_its_own_controller(hat: HatUnderTest, motor_port: int, second_motor_port: int) -> None:
    a, b = motor_port, second_motor_port
    drive(hat, a, "pwm ; plimit 1 ; set 0.6")
    drive(hat, b, "pwm ; set -0.6")
    sa, sb = speed(hat, a), speed(hat, b)
    drive(hat, a, "set 0")
    drive(hat, b, "set 0")
    hat.exchange("plimit 0.1")
    assert sa > 10 and sb < -10, f"port {a} set 0.6 -> {sa}; port {b} set -0.6 -> {sb}"
    start_quiet_pid(hat, a, sp="0.3")
    hat.exchange(f"port {b} ; select 3 ; set 0.7")
    lines = pid_lines(reports_after(hat, a, count=3), None)
    assert lines and {ln.port for ln in lines} == {a}, "only the port in PID mode prints PID lines"
    assert {ln.sp for ln in lines} == {"0.300000"}, "a set-point on another port must not leak"


@pytest.mark.req("CMD-PWM", "FW-PWM-KEEPS-GENERATOR")
def test_pwm_keeps_the_configured_setpoint(hat: HatUnderTest, motor_port: int) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-pwm: `pwm` zeroes the set-point for one tick only; the generator
    # keeps driving.
    p = motor_port
    start_quiet_pid(hat, p, sp="0.6")
    drive(hat, p, "plimit 1 ; debug 0 ; pwm")
    moving = speed(hat, p)
    hat.exchange("set 0 ; plimit 0.1")
    assert moving > 10, f"after pid, set 0.6, pwm: SPEED {moving}"


def mean_duty(levels: list) -> float:
    """Time-weighted mean of (HAT ms, duty) levels; the last entry only marks the end."""
    total = sum((t1 - t0) * (d if isinstance(d, int) else 0) for (t0, d), (t1, _n) in zip(levels, levels[1:]))
    return total / max(1, levels[-1][0] - levels[0][0])


# FIRMWARE-BEHAVIOUR#fb-pwm-path (R6+): u = (trunc(x*131072)+1)/2 toward 0; |u| < minpwm gives 0;
# |u| < pwmthresh is "slow PWM" (the threshold or 0, at u's average); duty = (v*255+127)>>16.
# set 0.2: u = 13107 -> 51; set 0.4: u = 26214 -> 102; threshold 0.5 = 32768 -> 127, -32768 -> -128;
# slow PWM at 0.2 is at the threshold 13107/32768 of the time.
PWM_PARAMS = [
    ("0 0", "0.2", {51}, 51.0),
    ("0 0", "0.149", {37}, 37.0),         # u = 9765: 9765*255 + 127 stays below 38 << 16
    ("0 0.3", "0.2", {0}, 0.0),
    ("0 0.3", "0.4", {102}, 102.0),
    ("0.5 0", "0.2", {0, 127}, 127 * 13107 / 32768),
    ("0.5 0", "-0.2", {0, -128}, -128 * 13106 / 32768),
]


@pytest.mark.req("FW-PWMPARAMS", "CMD-SET-CONST", "CMD-PWM")
@pytest.mark.parametrize("params,setpoint,duties,mean", PWM_PARAMS,
                         ids=[f"{p.replace(' ', '_')}-set{s}" for p, s, _d, _m in PWM_PARAMS])
def test_pwmparams_shape_the_drive(hat: HatUnderTest, world: PortNeeds, motor_port: int, params: str,
                                   setpoint: str,
                                   duties: set, mean: float) -> None:
    p = motor_port
    if not hat.has("pwmparams"):
        rejected(hat.exchange(f"port {p} ; pwmparams {params}"))
        return
    # Slow PWM carries an accumulator from the port's last slow-PWM drive, and a motor an earlier case
    # left in some state of its own may drop out mid-window (a port reset: drive 0 from there on).
    # A port reset first, where the world can (#fb-port-reset), so the window starts from defaults.
    world.replug(p)
    drive(hat, p, f"pwm ; plimit 1 ; pwmparams {params} ; set {setpoint}")
    try:
        hat.wait_ms(100)
        levels = world.drive_levels(p, 1000)
    finally:
        drive(hat, p, "set 0 ; pwmparams 0 0 ; plimit 0.1")
    seen = {d for _t, d in levels[:-1]}
    assert seen == duties, f"pwmparams {params}, set {setpoint}: drive levels {sorted(seen, key=str)}"
    assert abs(mean_duty(levels) - mean) <= 3, \
        f"pwmparams {params}, set {setpoint}: mean drive {mean_duty(levels):.1f}, {mean:.1f} expected"


@pytest.mark.req("CMD-PID", "FW-PID-LAW")
@pytest.mark.parametrize("sp,duty", [("2", 255), ("-2", -255)])
def test_pid_output_drives_the_motor(hat: HatUnderTest, world: PortNeeds, motor_port: int, sp: str,
                                     duty: int) -> None:
    # FIRMWARE-BEHAVIOUR#fb-pid: a set-point far from the process variable saturates the output at
    # ±1 (positive when the set-point is above it); #fb-pwm-path: with plimit 1, +1 drives 255 and
    # -1 drives -255. The shaft is held, so the error stays. APOS / 360: the PV is in turns, |PV| < 1.
    p = motor_port
    world.require("hold", "holding a motor's shaft")
    # Before the hold: an unknown build's PID syntax is undecided (UnknownBuild), and a hold not let
    # go would stop the motor in every later case.
    pid = hat.pid_command(p, 3, 0, "s2", "0.0027777778", "0", "100", "0", "0", "0")
    world.action(f"@hold {p} 1")
    try:
        drive(hat, p, f"select 3 ; plimit 1 ; {pid} ; set {sp}")
        hat.wait_ms(100)
        levels = world.drive_levels(p, 500)
    finally:
        drive(hat, p, "select ; pwm ; set 0 ; plimit 0.1")
        world.action(f"@hold {p} 0")
    seen = {d for _t, d in levels[:-1]}
    assert seen == {duty}, f"PID at set-point {sp} far from the PV: drive levels {sorted(seen, key=str)}"


@pytest.mark.req("CMD-CLEAR-FAULTS", "CMD-SET-CONST")
@pytest.mark.parametrize("setpoint,duty", [("0.4", 102), ("-0.4", -102)])
def test_clear_faults_leaves_the_drive_on_and_forwards(hat: HatUnderTest, world: PortNeeds, motor_port: int,
                                                       setpoint: str,
                                                      duty: int) -> None:
    # FIRMWARE-BEHAVIOUR#fb-commands: clear_faults writes 0x70 and then 0x7F to register 0x4C, the
    # driver's direction and enable flags; 0x7F is what a forward drive writes, and the driver is
    # written again only when the duty changes (#fb-pwm-path). So a port driving forwards keeps its
    # drive, and one driving backwards is driven forwards at the same size until its sign changes.
    p = motor_port
    drive(hat, p, f"pwm ; plimit 1 ; set {setpoint}")
    try:
        hat.wait_ms(50)
        before = world.drive_levels(p, 50)
        hat.exchange("clear_faults")
        after = world.drive_levels(p, 200)
    finally:
        drive(hat, p, "set 0 ; plimit 0.1")
    assert {d for _t, d in before[:-1]} == {duty}, f"set {setpoint}: drive {before}"
    assert {d for _t, d in after[:-1]} == {abs(duty)}, \
        f"set {setpoint}, then clear_faults: the drive must be {abs(duty)} (0x7F: on, forwards); got {after}"


@pytest.mark.req("CMD-PLIMIT", "FW-PLIMIT-CLAMP")
@pytest.mark.parametrize("outside,edge", [("2", "1"), ("-1", "0")])
def test_a_plimit_out_of_range_drives_as_its_edge(hat: HatUnderTest, world: PortNeeds, motor_port: int,
                                                  outside: str, edge: str) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-clamping: plimit is clamped to [0, 1] before it is stored, so a limit
    # outside drives exactly as the edge it is clamped to. The drive, not the motor's speed, tells a
    # limit of 0 from one the firmware did not clamp (which drove full reverse on the firmware in the loop).
    p = motor_port
    levels = {}
    try:
        for limit in (edge, outside):
            drive(hat, p, f"pwm ; plimit {limit} ; set 0.4")
            hat.wait_ms(50)
            levels[limit] = {d for _t, d in world.drive_levels(p, 200)[:-1]}
            drive(hat, p, "set 0")
    finally:
        drive(hat, p, "set 0 ; plimit 0.1")
    assert levels[outside] == levels[edge], (
        f"sent: plimit {outside} ; set 0.4, expected the drive of plimit {edge} (clamped to [0,1]): "
        f"{sorted(levels[edge], key=str)}; came: {sorted(levels[outside], key=str)}")


@pytest.mark.req("CMD-PWM", "FW-NO-DEVICE-NO-DRIVE")
def test_a_port_without_a_device_is_not_driven(hat: HatUnderTest, world: PortNeeds, empty_port: int) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-controller: at every controller tick a port with no device is driven
    # 0, whatever its set-point and limit say.
    p = empty_port
    drive(hat, p, "pwm ; plimit 1 ; set 1")
    try:
        hat.wait_ms(30)
        levels = world.drive_levels(p, 100)
    finally:
        drive(hat, p, "set 0 ; plimit 0.1")
    seen = {d for _t, d in levels[:-1]}
    assert seen == {0}, f"sent: pwm ; plimit 1 ; set 1 on port {p}, which has no device: expected drive 0; " \
                        f"came drive levels {sorted(seen, key=str)}"
