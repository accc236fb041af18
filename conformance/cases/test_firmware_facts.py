"""Behaviour the document leaves open and docs/FIRMWARE-BEHAVIOUR.md pins down (FW- IDs): select
edge cases, the R1-R4 / R5+ report engines, button events, per-port limits, `set var`."""
from __future__ import annotations

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import rejected
from ..needs import PortNeeds
from ..oracles.startup import START_UP, start_up_after_reset
from ..probes import TickClock, data_lines, pid_lines, reports_after, start_quiet_pid
from ..verdict import Verdict
from .test_drive import drive, speed


@pytest.mark.req("FW-SELECT-CLAMP", "CMD-SELECT-MODE")
def test_select_minus_one_selects_mode_0(hat: HatUnderTest, motor_port: int) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-clamping, #fb-vectors: the mode is clamped to 0..15, so -1 is
    # mode 0.
    p = motor_port
    reply = hat.exchange(f"port {p} ; select -1")
    lines = data_lines(reply.events + hat.wait_for(lambda e: e.text.startswith(f"P{p}M"), 2, 1500), p)
    assert reply.errors == 0 and lines and all(ln.startswith(f"P{p}M0:") for ln in lines), lines[:3]


@pytest.mark.req("FW-SELECT-BAD-FORMAT", "CMD-SELECT-OFF")
def test_select_with_offset_but_no_format_turns_reporting_off(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    hat.exchange(f"port {p} ; select 1")
    assert data_lines(hat.wait_for(lambda e: e.text.startswith(f"P{p}M1:"), 2, 1500), p), \
        f"sent `select 1` on port {p}: expected `P{p}M1:` lines, none came in 1.5 s"
    reply = hat.exchange("select 0 5")
    after = data_lines(hat.collect_ms(400), p)
    assert reply.raw == b"\r\nError\r\n" and not after, f"{reply.raw!r}; then {after[:3]}"


@pytest.mark.req("FW-SELONCE-TIMING", "CMD-SELONCE")
def test_selonce_first_report_timing(hat: HatUnderTest, motor_port: int) -> None:
    # R1-R4: about one 100 ms period after the data; R5+: with the first data
    # (docs/FIRMWARE-BEHAVIOUR.md#fb-reporting-r1, #fb-selonce-immediate).
    p = motor_port
    clock = TickClock(hat, p)              # PID on mode 3; selonce 1 below switches the mode
    reply = hat.exchange(f"port {p} ; selonce 1")
    events = reply.after_processing() + clock.run(400)   # ticks from when selonce ran
    ticks = clock.ticks_at(events, next((e.text for e in events if e.text.startswith(f"P{p}M1:")), "-"))
    hat.exchange("debug 0")
    assert len(ticks) == 1, f"selonce reports at ticks {ticks}"
    if hat.feature("selonce_first_report") == "immediate":
        assert ticks[0] <= 15, f"R5+: the report comes with the first data, not at tick {ticks[0]}"
    else:
        assert ticks[0] >= 5, f"R1-R4: the report waits a period after the data, not tick {ticks[0]}"


@pytest.mark.req("FW-BUTTON-EVENTS", "ID-PASSIVE")
def test_button_events(hat: HatUnderTest, world: PortNeeds) -> None:
    world.require("button", "pressing a touch sensor")
    p = world.passive(5)
    mark = hat.mark()
    world.action(f"@button {p} 1")
    hat.wait_for(lambda e: e.text == f"P{p}: button pressed", 1, 1500)
    world.action(f"@button {p} 0")
    hat.wait_for(lambda e: e.text == f"P{p}: button released", 1, 1500)
    texts = [e.text for e in hat.since(mark)]
    events = [t for t in texts if t in (f"P{p}: button pressed", f"P{p}: button released")]
    if hat.feature("button_events"):
        assert events == [f"P{p}: button pressed", f"P{p}: button released"], \
            f"pressed and released the button: expected `P{p}: button pressed`, then `released`; " \
            f"came {events}"
    else:
        assert not events, "R1 reports no button events (docs/FIRMWARE-BEHAVIOUR.md#fb-button)"


@pytest.mark.req("FW-PORT-PLIMIT", "CMD-PLIMIT")
def test_port_plimit_limits_one_port(hat: HatUnderTest, motor_port: int, second_motor_port: int) -> None:
    a, b = motor_port, second_motor_port
    if not hat.has("port_plimit"):
        rejected(hat.exchange(f"port {a} ; port_plimit 0.1"))
        return
    drive(hat, a, "pwm ; plimit 1 ; port_plimit 0.1 ; set 1")
    drive(hat, b, "pwm ; set 1")
    sa, sb = speed(hat, a), speed(hat, b)
    drive(hat, a, "set 0")
    drive(hat, b, "set 0 ; plimit 0.1")
    assert sb > 30 and sa < 0.5 * sb, f"port_plimit 0.1 on {a}: SPEED {sa}; port {b} at plimit 1: {sb}"


@pytest.mark.req("FW-SET-VAR", "CMD-PID-PV")
def test_set_var_takes_the_setpoint_from_a_sensor(hat: HatUnderTest, world: PortNeeds,
                                                  motor_port: int) -> None:
    p = motor_port
    if "var" not in hat.set_keywords:
        rejected(hat.exchange(f"port {p} ; set var 0 1 1 0 {p} 3 0 s2 1 0"))
        return
    world.require("data", "control of the motor's reported position (world @data)")
    world.action(f"@data {p} 3 2C 01")                       # APOS = 300
    try:
        start_quiet_pid(hat, p)
        # set-point = clamp((var - offset) * slope, min, max) = clamp((300 - 100) * 0.01, -1, 1.5)
        reply = hat.exchange(f"set var -1 1.5 0.01 100 {p} 3 0 s2 1 0")
        lines = pid_lines(reports_after(hat, p, count=3), p)
    finally:
        world.action(f"@data {p} 3 auto")
    assert reply.errors == 0 and lines and lines[-1].sp == "1.50000", [ln.sp for ln in lines][:5]


@pytest.mark.req("FW-STARTUP", "LINK-TEXT")
def test_start_up_lines(hat: HatUnderTest, world: PortNeeds, verdict: Verdict) -> None:
    world.require("reset", "resetting the HAT (its reset line)")
    active = [e.port for e in world.layout() if e.kind == "active"]
    mark = hat.mark()
    world.action("@reset")
    if not hat.watch(mark, lambda e: e.text == START_UP[-1], 8000) \
            and any(e.text == START_UP[1] for e in hat.since(mark)):
        # The banner came, the rest did not: a HAT hung after it (a target fault, below), or one
        # waiting for input it should only throw away? One CR tells them apart.
        hat.send(b"\r")
        assert not hat.watch(mark, lambda e: e.text == START_UP[-1], 2000), \
            ("the start-up stopped after its banner until the host sent a byte; it goes on by itself, "
             "input only being thrown away for 10 ms (docs/FIRMWARE-BEHAVIOUR.md#fb-boot-input)")
    hat.expect(lambda e: e.text == START_UP[-1] and e in hat.since(mark), 8000)
    texts = [e.text for e in hat.since(mark)]
    # The devices connect again after the start-up; the next cases expect them up.
    def waiting() -> list:
        up = {e.text[1] for e in hat.since(mark) if e.text[2:].startswith(": established")}
        return [p for p in active if str(p) not in up]

    while waiting():
        ports = {str(p) for p in waiting()}
        hat.expect(lambda e, ports=ports: e.text[2:].startswith(": established") and e.text[1] in ports, 8000)
    hat.powered_ports = ()
    # FIRMWARE-BEHAVIOUR#fb-startup, every line exactly; the bytes of a line the reset cut may come
    # glued before its first (empty) line: sent before the reset, they are no start-up output.
    start_up = start_up_after_reset(texts)
    assert start_up.lines, f"no empty line then {START_UP[1]!r} after the reset: {texts[:10]!r}"
    assert start_up.lines == START_UP, f"start-up lines: {start_up.lines!r}"
    if start_up.leftover:
        verdict.note(f"the reset cut a line the HAT was sending: {start_up.leftover!r} came before the "
                     "start-up's empty line (docs/FIRMWARE-BEHAVIOUR.md#fb-startup)")
    # No prompt at start-up (echo is 0, FIRMWARE-BEHAVIOUR#fb-prompt).
    prompts = [e.text for e in hat.since(mark) if e.kind == "prompt"]
    assert not prompts, f"a prompt came with the start-up lines: {prompts!r}"
