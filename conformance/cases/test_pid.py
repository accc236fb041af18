"""PID control as `debug 16` shows it, recomputed line by line in float32.

Document: CMD-PID (parameters), CMD-PID-PV (port, mode, offset, format, scale), CMD-PID-SELECT,
CMD-PID-UNWRAP, CMD-PID-TIME (1 s time unit), CMD-PID-WINDUP, CMD-PWM, CMD-OFF, CMD-ON.
Exact law from docs/FIRMWARE-BEHAVIOUR.md#fb-pid-law: e = PV - SP (deadzone), de = (e - e_prev)/0.01,
ie = clamp(ie + e*0.01), output = -(e*Kp + ie*Ki + de*Kd). The oracle is oracles/pid.py.
"""
from __future__ import annotations

import struct
from typing import Dict, List, Optional, TypedDict

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import accepted, rejected, same
from ..needs import PortNeeds
from ..oracles.float32 import f32
from ..oracles.floatfmt import fw_float
from ..oracles.numbers import parse_float
from ..oracles.pid import PidLine, PidModel, Unwrapper, close_to_printed
from ..probes import MOTOR, pid_lines, reports_after, start_quiet_pid
from ..verdict import Verdict

FIELDS = ("e", "ie", "de", "cv")


def _num(text: str) -> float:
    value, _end = parse_float(text)
    assert value is not None, f"the suite's own PID parameter {text!r} is no number"
    return value


def _le16(value: int) -> str:
    return " ".join(f"{b:02X}" for b in struct.pack("<h", value))


class _Gains(TypedDict):
    """The gain arguments of :func:`_run_pid`, as typed on the command line."""
    scale: str
    unwrap: str
    kp: str
    ki: str
    kd: str
    windup: str
    deadzone: str


def _run_pid(hat: HatUnderTest, port: int, *, scale: str, unwrap: str, kp: str, ki: str, kd: str, windup: str,
             deadzone: str, sp: str, mode: int = 3, fmt: str = "s2", offset: int = 0,
             differentiate: bool = False) -> None:
    pid = hat.pid_command(port, mode, offset, fmt, scale, unwrap, kp, ki, kd, windup, deadzone, differentiate)
    reply = hat.exchange(f"port {port} ; select {mode} ; {pid} ; set {sp} ; debug 16")
    assert reply.errors == 0, f"`{pid}` was refused: {reply.raw!r}"


def _deadzone(hat: HatUnderTest, text: str):
    # R1-R5 have a fixed band (-0.01, 0.01); R6+ take it as the 11th parameter
    # (docs/FIRMWARE-BEHAVIOUR.md#fb-pid-law).
    return _num(text) if hat.feature("pid_deadzone") == "parameter" else None


def recompute(lines: List[PidLine], pv_of: Dict[str, float], sp: float, model: PidModel) -> List[str]:
    """Differences between each printed line and the model stepped from the previous one."""
    problems = []
    for n, line in enumerate(lines):
        assert line.pv in pv_of, f"line {n}: pv={line.pv} is none of the values the device sent"
        want = dict(zip(FIELDS, model.step(pv_of[line.pv], sp)))
        for name in FIELDS:
            if not close_to_printed(getattr(line, name), want[name]):
                problems.append(f"line {n} ({line.pv}): {name}={getattr(line, name)}, "
                                f"float32 recomputation gives {fw_float(want[name])}")
    return problems


@pytest.mark.req("CMD-PID", "CMD-PID-PV", "CMD-PID-TIME", "CMD-PID-WINDUP", "FW-PID-LAW", "FW-PID-DEADZONE")
def test_pid_lines_match_a_float32_recomputation(hat: HatUnderTest, world: PortNeeds,
                                                 motor_port: int) -> None:
    world.require("data", "control of the motor's reported position (world @data)")
    p = motor_port
    gains = _Gains(scale="0.01", unwrap="0", kp="2.5", ki="1.5", kd="0.05", windup="0.1", deadzone="0.05")
    sp_text = "0.5"
    raws = [0, 40, -25, 300, 48, 49, 51, -300, 2]       # 48/49/51: errors inside/at the deadzone
    world.action(f"@data {p} 3 {_le16(raws[0])}")
    try:
        _run_pid(hat, p, sp=sp_text, **gains)
        # e = -0.5 for 20+ ticks saturates the integrator at -windup: a known, exact state.
        events = hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv=") and "ie=-0.100000" in e.text, 3, 2000)
        for raw in raws[1:]:
            world.action(f"@data {p} 3 {_le16(raw)}")
            events += hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 6, 1000)
    finally:
        world.action(f"@data {p} 3 auto")
    lines = pid_lines(events, p)
    scale = _num(gains["scale"])
    pv_of = {fw_float(f32(r * scale)): f32(r * scale) for r in raws}
    # Start from the first line with the integrator saturated and a steady error.
    k = next(i for i in range(1, len(lines)) if lines[i].ie == lines[i - 1].ie == "-0.100000"
             and lines[i].e == lines[i - 1].e and lines[i].pv == fw_float(0.0))
    sp = _num(sp_text)
    e0 = f32(pv_of[lines[k].pv] - sp)
    model = PidModel(_num(gains["kp"]), _num(gains["ki"]), _num(gains["kd"]), _num(gains["windup"]),
                     _deadzone(hat, gains["deadzone"]), ie=-_num(gains["windup"]), e_prev=e0)
    problems = recompute(lines[k + 1:], pv_of, sp, model)
    assert not problems, "\n".join(problems[:12])
    seen = {ln.pv for ln in lines[k + 1:]}
    assert len(seen) >= len(set(raws)) - 1, f"not every data value reached the controller: {seen}"
    # The document's windup statement, independently of the exact arithmetic:
    over = [ln.value("ie") for ln in lines if abs(ln.value("ie")) > _num(gains["windup"]) * (1 + 1e-6)]
    assert not over, f"the integral must stay within the windup limit {gains['windup']}; came {over[:6]}"


@pytest.mark.req("CMD-PID", "CMD-PID-TIME", "CMD-PID-WINDUP", "FW-PID-LAW")
def test_pid_lines_are_self_consistent_on_live_data(hat: HatUnderTest, motor_port: int) -> None:
    # Any target (a real motor included): each line's e, ie, de, cv must follow from its pv,
    # sp and the previous line, to the 6 digits printed.
    p = motor_port
    hat.exchange("plimit 0.1")
    _run_pid(hat, p, scale="0.0027777778", unwrap="1", kp="0.8", ki="0.3", kd="0.01", windup="0.05",
             deadzone="0.001", sp="0.2")
    events = hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 60, 2000)
    lines = pid_lines(events, p)
    assert len(lines) >= 30, f"only {len(lines)} PID lines in 2 s of HAT time"
    kp, ki, kd, windup = 0.8, 0.3, 0.01, 0.05
    for prev, line in zip(lines, lines[1:]):
        pv, sp, e, ie, de, cv = (line.value(n) for n in ("pv", "sp", "e", "ie", "de", "cv"))
        tol = 2e-5 * max(1.0, abs(pv), abs(sp))
        if e != 0:
            assert abs(e - (pv - sp)) <= tol, f"{line}: e is not pv - sp"
        assert abs(de - (e - prev.value("e")) / 0.01) <= 100 * tol + 1e-3 * abs(de), f"{line}: de"
        expected_ie = max(-windup, min(windup, prev.value("ie") + e * 0.01))
        assert abs(ie - expected_ie) <= tol, f"{line}: ie is not clamp(ie_prev + e*0.01)"
        assert abs(cv + (e * kp + ie * ki + de * kd)) <= 1e-4 * max(1.0, abs(cv)) + 100 * tol * kd, \
            f"{line}: cv is not -(e*Kp + ie*Ki + de*Kd)"


@pytest.mark.req("CMD-PID-UNWRAP", "FW-PID-UNWRAP-INIT")
def test_unwrap_across_plus_minus_180(hat: HatUnderTest, world: PortNeeds, verdict: Verdict,
                                      motor_port: int) -> None:
    world.require("data", "control of the motor's reported position (world @data)")
    p = motor_port
    # R1-R5 keep the unwrapped PV until a port reset (#fb-unwrap-r1): one an earlier case left (a u4
    # read, 3e9) leaves no float32 steps of 1 to see. A port reset where the world can.
    world.replug(p)
    raws = [170, 179, -180, -170, 175, -175, 0, 90, -91]
    world.action(f"@data {p} 3 {_le16(raws[0])}")
    try:
        hat.wait_ms(150)
        # A PID with another scale and modulo first: whatever state an unwrapper keeps across `pid`
        # commands then shows (docs/FIRMWARE-BEHAVIOUR.md#fb-doc-unwrap); the document's guarantee
        # must not depend on it.
        _run_pid(hat, p, scale="0.37", unwrap="1", kp="0", ki="0", kd="0", windup="0", deadzone="0", sp="0")
        hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 3, 1000)
        _run_pid(hat, p, scale="1", unwrap="360", kp="0", ki="0", kd="0", windup="0", deadzone="0", sp="0")
        events = hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 3, 1000)
        for raw in raws[1:]:
            last = pid_lines(events, p)[-1].pv if pid_lines(events, p) else None
            world.action(f"@data {p} 3 {_le16(raw)}")
            # Wait for the new value to reach the controller, then a couple more ticks.
            old = f"pv={last} "
            events += hat.wait_for(lambda e, old=old: e.text.startswith(f"P{p}: pv=") and old not in e.text,
                                   1, 1000)
            events += hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 2, 1000)
    finally:
        world.action(f"@data {p} 3 auto")
    pvs = [ln.value("pv") for ln in pid_lines(events, p)]
    runs = [v for i, v in enumerate(pvs) if i == 0 or v != pvs[i - 1]]
    assert len(runs) == len(raws), f"expected one pv per data value {raws}, got {runs}"
    for raw, prev_raw, pv, prev_pv in zip(raws[1:], raws, runs[1:], runs):
        # Document: the smallest change between samples...
        step = (raw - prev_raw + 180) % 360 - 180
        assert abs(pv - prev_pv - step) < 1e-3, f"{prev_raw} -> {raw}: pv moved {pv - prev_pv}, not {step}"
    # ... and equal to the input modulo 360.
    offsets = [round((pv - raw + 180) % 360 - 180, 3) for pv, raw in zip(runs, raws)]
    congruent = all(abs(o) < 1e-3 for o in offsets)
    constant = max(offsets) - min(offsets) < 1e-2
    verdict.document(congruent, key="UNWRAP-STATE-PERSISTS", firmware_ok=constant,
                     seen=f"data {raws} gave pv {runs}")
    model = Unwrapper(1, 360, first_sample=hat.feature("unwrap_init") == "first_sample")
    if model.first_sample:
        assert runs[0] == raws[0], \
            "R6+: the first sample after `pid` is taken as it is (docs/FIRMWARE-BEHAVIOUR.md#fb-unwrap-r6)"


@pytest.mark.req("FW-PID-DIFF", "CMD-PID-UNWRAP")
def test_pid_diff_differentiates_the_process_variable(hat: HatUnderTest, world: PortNeeds,
                                                      motor_port: int) -> None:
    p = motor_port
    if not hat.has("pid_diff"):
        rejected(hat.exchange("pid_diff 0 3 0 s2 1 0 0 0 0 0 0"))
        return
    world.require("data", "control of the motor's reported position (world @data)")
    world.action(f"@data {p} 3 {_le16(170)}")
    try:
        hat.wait_ms(150)
        _run_pid(hat, p, scale="1", unwrap="360", kp="0", ki="0", kd="0", windup="0", deadzone="0", sp="0",
                 differentiate=True)
        events = hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 4, 1000)
        world.action(f"@data {p} 3 {_le16(-170)}")
        events += hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv=") and "pv=0.00000" not in e.text,
                               1, 1000)
        events += hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 3, 1000)
    finally:
        world.action(f"@data {p} 3 auto")
    pvs = [ln.pv for ln in pid_lines(events, p)]
    nonzero = [v for v in pvs if v != "0.00000"]
    # 170 -> -170 unwraps to +20 degrees in one 10 ms tick: 20 * 100 per tick
    # (docs/FIRMWARE-BEHAVIOUR.md#fb-unwrap-r6).
    assert nonzero == ["2000.00"], f"pid_diff pv sequence {pvs}"


@pytest.mark.req("CMD-PID-PV")
@pytest.mark.parametrize("fmt,offset,scale", [
    ("u1", 0, "1"), ("s1", 0, "1"), ("u2", 1, "1"), ("s2", 2, "0.5"),
    ("u4", 3, "1"), ("s4", 4, "1"), ("f4", 8, "2")])
def test_process_variable_format_offset_and_scale(hat: HatUnderTest, world: PortNeeds, motor_port: int,
                                                  fmt: str,
                                                  offset: int, scale: str) -> None:
    world.require("data", "control of the motor's mode data (world @data)")
    p = motor_port
    payload = bytes([0xF6, 0x85, 0xFE, 0x7F, 0x80, 0x01, 0xC3, 0x9A]) + struct.pack("<f", -12.375) + bytes(16)
    world.action(f"@data {p} 5 " + " ".join(f"{b:02X}" for b in payload))
    try:
        _run_pid(hat, p, scale=scale, unwrap="0", kp="0", ki="0", kd="0", windup="0", deadzone="0", sp="0",
                 mode=5, fmt=fmt, offset=offset)
        lines = pid_lines(hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 3, 1000), p)
    finally:
        world.action(f"@data {p} 5 auto")
    code = {"u1": "<B", "s1": "<b", "u2": "<H", "s2": "<h", "u4": "<I", "s4": "<i", "f4": "<f"}[fmt]
    raw = struct.unpack_from(code, payload, offset)[0]
    expected = fw_float(f32(f32(raw) * _num(scale)))
    assert lines and lines[-1].pv == expected, f"{fmt} at {offset} x {scale}: pv {[ln.pv for ln in lines]}"


@pytest.mark.req("CMD-PID-SELECT")
def test_pid_needs_the_mode_selected(hat: HatUnderTest, world: PortNeeds, motor_port: int) -> None:
    p = motor_port
    if world.can("plug"):
        world.unplug(p)          # a fresh connection: no mode has data yet
        p = world.active(0x30)
    pid = hat.pid_command(p, 4, 0, "s2", "1", "0", "0", "0", "0", "0", "0")
    hat.exchange(f"port {p} ; {pid} ; debug 16")
    before = pid_lines(hat.collect_ms(300), p)
    hat.exchange(f"port {p} ; select 4")
    after = pid_lines(hat.wait_for(lambda e: e.text.startswith(f"P{p}: pv="), 3, 1000), p)
    assert not before, "PID ran on a mode that has never been selected"
    assert after, "PID did not start once its mode was selected"


@pytest.mark.req("CMD-PID")
def test_document_ten_parameter_pid(hat: HatUnderTest, verdict: Verdict, motor_port: int) -> None:
    p = motor_port
    reply = hat.exchange(f"port {p} ; select 0 ; combi 0 1 0 2 0 3 0 ; select 0 ; plimit 0.1 ; debug 16")
    accepted(reply)
    doc = hat.exchange("pid 0 0 5 s2 0.0027777778 1 5 0 .1 3".replace("pid 0", f"pid {p}", 1))
    running = bool(pid_lines(reports_after(hat, p), p))
    verdict.document(doc.errors == 0 and running, key="PID-DOC-ARGS-REJECTED",
                     firmware_ok=doc.raw == b"\r\nError\r\n" and not running,
                     seen=f"{doc.raw!r}, PID lines {'seen' if running else 'absent'}")


@pytest.mark.req("CMD-PID", "FW-PID-ELEVEN")
def test_eleven_parameter_pid(hat: HatUnderTest, motor_port: int) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-pid-command: R6+ accept it; R1-R5 apply the first ten, then
    # `0.01` is an Error.
    p = motor_port
    hat.exchange(f"port {p} ; select 3 ; debug 16")
    reply = hat.exchange(f"pid {p} 3 0 s2 0 0 0 0 0 0 0.01")
    running = bool(pid_lines(reports_after(hat, p), p))
    assert running, "the PID must run either way"
    same(reply, b"\r\n" if hat.feature("pid_numbers") >= 11 else b"\r\nError\r\n")


@pytest.mark.req("CMD-OFF", "CMD-ON")
@pytest.mark.parametrize("command,value,key", [("off", "0.00000", "OFF-KEEPS-PID"),
                                               ("on", "1.00000", "ON-KEEPS-PID")])
def test_off_and_on_in_pid_mode(hat: HatUnderTest, verdict: Verdict, motor_port: int, command: str,
                                value: str,
                                key: str) -> None:
    start_quiet_pid(hat, motor_port, sp="0.5")
    reply = hat.exchange(command)
    lines = pid_lines(reports_after(hat, motor_port), motor_port)
    accepted(reply)
    # Document: `off` = `pwm ; set 0`, so PID lines stop. Firmware: still PID, set-point 0/1.
    sps = sorted({ln.sp for ln in lines})
    verdict.document(not lines, key=key, firmware_ok=bool(lines) and sps == [value],
                     seen=f"after `{command}`: {len(lines)} PID lines, set-points {sps}")


@pytest.mark.req("CMD-PWM", "CMD-COAST", "FW-COAST-STOPS-CONTROLLER")
@pytest.mark.parametrize("command", ["pwm", "coast"])
def test_pwm_and_coast_leave_pid_mode(hat: HatUnderTest, motor_port: int, command: str) -> None:
    start_quiet_pid(hat, motor_port)
    reply = hat.exchange(command)
    lines = pid_lines(reports_after(hat, motor_port), motor_port)
    assert reply.raw == b"\r\n" and not lines, f"{command}: {len(lines)} PID lines after it"


@pytest.mark.req("CMD-DEBUG", "FW-DEBUG-16", "CMD-PID-TIME")
def test_debug_16_prints_one_pid_line_per_tick(hat: HatUnderTest, motor_port: int) -> None:
    # Two clocks inside the HAT: PID lines (one per 10 ms tick) against the selected mode's reports
    # (one per 100 ms, docs/FIRMWARE-BEHAVIOUR.md#fb-reporting): ten lines per report, whatever the
    # wall clock does.
    p = motor_port
    start_quiet_pid(hat, p)
    events = hat.wait_for(lambda e: e.text.startswith(f"P{p}M3:"), 31, 10000)
    texts = [e.text for e in events]
    first = texts.index(next(t for t in texts if t.startswith(f"P{p}M3:")))
    last = len(texts) - 1 - texts[::-1].index(next(t for t in texts[::-1] if t.startswith(f"P{p}M3:")))
    between = texts[first:last]
    ticks = sum(1 for t in between if t.startswith(f"P{p}: pv="))
    reports = sum(1 for t in between if t.startswith(f"P{p}M3:"))
    assert reports >= 25 and abs(ticks / reports - 10) <= 1.0, f"{ticks} PID lines for {reports} reports"
    hat.exchange("debug 0")
    assert not pid_lines(hat.collect_ms(200), p), "debug 0 must stop the PID lines"


# (what the sensor variable names, the highest value the HAT has, one past it): fb-svar-clamp.
SVAR_LIMITS = [("port", 3, 4), ("mode", 15, 16), ("offset", 127, 128)]
SVAR_CASES = [(field, top, beyond, kind) for field, top, beyond in SVAR_LIMITS for kind in ("pid", "set var")
              if not (field == "mode" and kind == "set var")]


def _last_pid_line(hat: HatUnderTest, port: int, data_port: int, line: str) -> Optional[PidLine]:
    """The last `debug 16` line of ``port`` while ``line`` runs there (None: it printed none), over
    three data reports of ``data_port`` (about 30 controller ticks, however slow the target)."""
    sent = f"port {port} ; {line} ; debug 16"
    reply = hat.exchange(sent)
    assert reply.errors == 0, f"sent `{sent}`; the HAT answered {reply.raw!r}"
    lines = pid_lines(reply.events + reports_after(hat, data_port, count=3), port)
    hat.exchange("debug 0")
    return lines[-1] if lines else None


@pytest.mark.req("CMD-PID-PV", "FW-SVAR-CLAMP")
@pytest.mark.parametrize("field,top,beyond,kind", SVAR_CASES,
                         ids=[f"{kind.replace(' ', '_')}-{field}{beyond}"
                              for field, _t, beyond, kind in SVAR_CASES])
def test_a_variable_the_hat_does_not_have_reads_its_last(hat: HatUnderTest, world: PortNeeds,
                                                         motor_port: int, field: str,
                                                         top: int, beyond: int, kind: str) -> None:
    # FIRMWARE-BEHAVIOUR#fb-svar-clamp: a sensor variable's port, mode and offset are clamped to 0..3,
    # 0..15 and 0..127, so naming one past the last does exactly what naming the last does.
    if kind == "set var" and "var" not in hat.set_keywords:
        pytest.skip("`set var` is R6+ (docs/FIRMWARE-BEHAVIOUR.md#fb-set-keywords)")
    world.require("data", "choosing what a device sends (@data)")
    p = motor_port
    if field == "port":
        # port 3 has a motor whose APOS is 300; the controller runs there, reading port 3 or 4
        world.plug(3, ("active", MOTOR))
        p, data_port, select = 3, 3, "select 3"
        svar = {"mode": 3, "offset": 0, "fmt": "s2", "scale": "0.01"}
    elif field == "mode":
        data_port, select = p, "select 3"
        svar = {"port": p, "offset": 0, "fmt": "s2", "scale": "1"}
    else:
        # mode 3 holds APOS 300 (2C 01), then mode 2's data comes: offsets past mode 2's data
        data_port, select = p, "select 3 ; select 2"
        svar = {"port": p, "mode": 2, "fmt": "u1", "scale": "1"}
    world.action(f"@data {data_port} 3 2C 01")
    try:
        hat.exchange(f"port {data_port} ; select 3")
        reports_after(hat, data_port, count=1)
        hat.exchange(f"port {data_port} ; {select}")
        seen = {}
        for value in (top, beyond):
            args = {name: str(v) for name, v in dict(svar, **{field: value}).items()}
            if kind == "pid":
                line = hat.pid_command(int(args["port"]), int(args["mode"]), int(args["offset"]), args["fmt"],
                                       args["scale"], "0", "0", "0", "0", "0", "0") + " ; set 0"
            else:
                quiet = hat.pid_command(p, 3, 0, "s2", "0", "0", "0", "0", "0", "0", "0")
                line = (f"{quiet} ; set var -1000 1000 1 0 {args['port']} {args['mode']} {args['offset']} "
                        f"{args['fmt']} {args['scale']} 0")
            got = _last_pid_line(hat, p, data_port, line)
            seen[value] = (line, None if got is None else (got.pv if kind == "pid" else got.sp))
    finally:
        hat.exchange(f"port {data_port} ; select ; port {p} ; pwm ; set 0 ; debug 0")
        world.action(f"@data {data_port} 3 auto")
    (line_top, at_top), (line_beyond, at_beyond) = seen[top], seen[beyond]
    what = "pv" if kind == "pid" else "sp"
    assert at_beyond == at_top, (
        f"sent `{line_beyond}` on port {p}: the {field} {beyond} is one past the HAT's last, which "
        f"docs/FIRMWARE-BEHAVIOUR.md#fb-svar-clamp says reads the {field} {top}; `{line_top}` gave "
        f"{'no PID line' if at_top is None else what + '=' + at_top}, this gave "
        f"{'no PID line' if at_beyond is None else what + '=' + at_beyond}")
