"""`set` waveforms, sampled tick by tick through `debug 16` and compared with oracles/waveform.py.

Document: CMD-SET-SQUARE/SINE/TRIANGLE (min max period phase), CMD-SET-PHASE, CMD-SET-PULSE,
CMD-SET-RAMP (4th parameter ignored), CMD-SET-DONE. Exact generator:
docs/FIRMWARE-BEHAVIOUR.md#fb-setpoint (10 ms ticks, float32 phase accumulator, 256-entry sine
table, period/phase clamps).
Timing: each PID line is one 10 ms tick of HAT time, so shape, amplitude, period and phase
are checked in ticks; wall-clock times are only bounded from below (a message cannot be
early) and loosely from above, scaled by the target's time scale.
"""
from __future__ import annotations

from typing import List, Optional, Tuple

import pytest

from ..hat_under_test import HatUnderTest, Reply
from ..mismatch import accepted, rejected
from ..oracles.numbers import parse_float
from ..oracles.pid import close_to_printed
from ..oracles.waveform import Generator, ticks_until_done
from ..probes import pid_lines, start_quiet_pid
from ..verdict import Verdict

OLD_SP = "7"              # a set-point no waveform below produces: marks where the new one starts


def _n(text: str) -> float:
    value, _ = parse_float(text)
    assert value is not None, f"the suite's own parameter {text!r} is no number"
    return value


def capture(hat: HatUnderTest, port: int, command: str, ticks: int) -> Tuple[List[str], List, float, Reply]:
    """Send ``command`` with the port in quiet PID mode; return the set-points of the first
    ``ticks`` ticks after it, all events, the send time and the reply."""
    start_quiet_pid(hat, port, sp=OLD_SP)
    mark = hat.mark()
    sent_at = hat.clock()
    reply = hat.exchange(command)
    hat.wait_for(lambda e: e.text.startswith(f"P{port}: pv="), ticks + 3, ticks * 10 * 2 + 1000)
    events = hat.since(mark)
    sps = [ln.sp for ln in pid_lines(events, port)]
    old = f"{_n(OLD_SP):.5f}"
    while sps and sps[0] == old:
        sps.pop(0)
    return sps[:ticks], events, sent_at, reply


def events_t0(hat: HatUnderTest, monotonic: float) -> float:
    """A :meth:`HatUnderTest.clock` instant on the clock of ``Event.t`` (ms since the session opened)."""
    return hat.session.now_ms() - (hat.clock() - monotonic) * 1000.0


def mismatches(seen: List[str], model: List[float]) -> List[str]:
    out = [f"tick {i + 1}: {s} instead of {m}" for i, (s, m) in enumerate(zip(seen, model))
           if not close_to_printed(s, m)]
    if len(seen) < len(model):
        out.append(f"only {len(seen)} of {len(model)} ticks seen")
    return out


WAVES = [
    ("square", "0 1 0.2 0", 45), ("square", "0.25 0.75 0.2 0.25", 45), ("square", "-1 -0.5 0.3 0.9", 65),
    ("sine", "-1 1 0.5 0", 60), ("sine", "0 1 0.3 0.5", 40), ("sine", "2 3 0.64 0.125", 70),
    ("triangle", "0 1 0.2 0", 45), ("triangle", "-0.5 0.5 0.4 0.75", 50),
]


@pytest.mark.req("CMD-SET-SQUARE", "CMD-SET-SINE", "CMD-SET-TRIANGLE", "CMD-SET-PHASE", "FW-WAVE-TICKS")
@pytest.mark.parametrize("shape,args,ticks", WAVES, ids=[f"{s} {a}" for s, a, _ in WAVES])
def test_periodic_waveform_tick_by_tick(hat: HatUnderTest, motor_port: int, shape: str, args: str,
                                        ticks: int) -> None:
    seen, _events, _t, reply = capture(hat, motor_port, f"set {shape} {args}", ticks)
    accepted(reply)
    a, b, period, phase = (_n(x) for x in args.split())
    model = [v for v, _done in Generator(shape, a, b, period, phase).run(ticks)]
    problems = mismatches(seen, model)
    assert not problems, "\n".join(problems[:10])
    # The document's terms, from the same samples: amplitude within [min, max], both reached.
    values = [float(s) for s in seen]
    assert min(values) >= min(a, b) - 1e-5 and max(values) <= max(a, b) + 1e-5, \
        f"set {shape} {args}: expected set-points within [{min(a, b)}, {max(a, b)}], " \
        f"came {min(values)}..{max(values)}"


def _done_check(hat: HatUnderTest, port: int, shape: str, args: str) -> Tuple[List[str], List[float],
                                                                              Optional[str]]:
    a, b, period, phase = (_n(x) for x in args.split())
    n = ticks_until_done(period)
    seen, events, sent_at, reply = capture(hat, port, f"set {shape} {args}", n + 10)
    accepted(reply)
    texts = [e.text for e in events]
    done_line = f"P{port}: {shape} done"
    # CMD-SET-DONE: the document's message, as the firmware words it
    # (docs/FIRMWARE-BEHAVIOUR.md#fb-doc-done-lines).
    assert texts.count(done_line) == 1, f"expected one `{done_line}`, got {[t for t in texts if 'done' in t]}"
    # It comes in tick n: after the line of tick n-1, before the line of tick n
    # (docs/FIRMWARE-BEHAVIOUR.md#fb-waveform-end).
    i = texts.index(done_line)
    before = [ln.sp for ln in pid_lines(events[:i], port)]
    old = f"{_n(OLD_SP):.5f}"
    while before and before[0] == old:
        before.pop(0)
    problem = None if len(before) == n - 1 else f"`{done_line}` after {len(before)} ticks, not {n - 1}"
    # In wall-clock terms: late only within a generous, scaled margin; "not early" only at
    # time scale 1 (a sped-up emulator may run faster for a while to catch up on a lag).
    elapsed_hat = (events[i].t - events_t0(hat, sent_at)) * hat.time_scale
    assert elapsed_hat <= n * 10 * 2 + 1500 * hat.time_scale, f"`{done_line}` late: {elapsed_hat:.0f} ms"
    if hat.time_scale == 1:
        assert elapsed_hat >= (n - 1) * 10 - 15, f"`{done_line}` {elapsed_hat:.0f} ms after the command"
    model = [v for v, _d in Generator(shape, a, b, period, phase).run(n + 10)]
    return seen, model, problem


@pytest.mark.req("CMD-SET-PULSE", "CMD-SET-DONE", "FW-WAVE-TICKS")
@pytest.mark.parametrize("args", ["0.8 0.2 0.15 0", "1 0 0.1 0", "-0.3 0.6 0.5 0.5"])
def test_pulse_holds_then_settles_and_reports_done(hat: HatUnderTest, motor_port: int, args: str) -> None:
    seen, model, problem = _done_check(hat, motor_port, "pulse", args)
    assert problem is None, problem
    problems = mismatches(seen, model)
    assert not problems, "\n".join(problems[:10])


@pytest.mark.req("CMD-SET-RAMP", "CMD-SET-DONE", "FW-WAVE-TICKS")
@pytest.mark.parametrize("args", ["0 1 0.2 0", "1 -1 0.3 0"])
def test_ramp_runs_linearly_and_reports_done(hat: HatUnderTest, motor_port: int, args: str) -> None:
    seen, model, problem = _done_check(hat, motor_port, "ramp", args)
    assert problem is None, problem
    problems = mismatches(seen, model)
    assert not problems, "\n".join(problems[:10])


# docs/FIRMWARE-BEHAVIOUR.md#fb-setpoint: a pulse ends on tick n of its float accumulator
# (ticks_until_done) and the first tick comes 0-10 ms after the command, so `done` is printed
# (n-1)*10 to n*10 ms after the CR. For these lengths (n-1)*10 ms is the length or more: no HAT
# reports them done early. Not for every length: 5 s ends on tick 500, up to 10 ms before 5 s have
# passed (0.2 s, 0.3 s, 10 s too).
NOT_EARLY_LENGTHS = ["0.1", "0.5", "1"]


@pytest.mark.req("CMD-SET-PULSE", "CMD-SET-DONE", "FW-WAVE-TICKS")
@pytest.mark.parametrize("length", NOT_EARLY_LENGTHS)
def test_pulse_done_never_comes_before_its_length(hat: HatUnderTest, motor_port: int, length: str) -> None:
    """Issue 27: a host that times `set pulse` from its own clock never sees `done` early. HAT time
    is measured from just before the line is sent, so the link's delays only lengthen it."""
    n = ticks_until_done(_n(length))
    length_ms = round(float(length) * 1000)          # whole ms: the float32 length is 0.1 s + 1.5 ns
    assert (n - 1) * 10 >= length_ms, \
        f"docs/FIRMWARE-BEHAVIOUR.md#fb-setpoint lets a {length} s pulse end early; not a case"
    p = motor_port
    drive_off = hat.exchange(f"port {p} ; pwm ; set 0")       # direct PWM at 0: the motor never moves
    accepted(drive_off)
    mark = hat.mark()
    sent_ms = hat.session.now_ms()
    reply = hat.exchange(f"port {p} ; set pulse 0 0 {length} 0")
    accepted(reply)
    done_line = f"P{p}: pulse done"
    assert hat.watch(mark, lambda e: e.text == done_line, n * 10 + 2000), f"no `{done_line}`"
    done = next(e for e in hat.since(mark) if e.text == done_line)
    elapsed_hat = (done.t - sent_ms) * hat.time_scale
    assert elapsed_hat >= length_ms, (f"`{done_line}` {elapsed_hat:.1f} ms of HAT time after "
                                           f"`set pulse ... {length} ...` was sent")


@pytest.mark.req("CMD-SET-RAMP", "CMD-SET-PHASE")
def test_ramp_fourth_parameter(hat: HatUnderTest, verdict: Verdict, motor_port: int) -> None:
    a, b, period = 0.0, 1.0, _n("0.2")
    ticks = ticks_until_done(period) + 3
    seen, _e, _t, reply = capture(hat, motor_port, "set ramp 0 1 0.2 0.5", ticks)
    accepted(reply)
    document = [v for v, _d in Generator("ramp", a, b, period, 0).run(ticks)]
    firmware = [v for v, _d in Generator("ramp", a, b, period, _n("0.5")).run(ticks)]
    verdict.document(not mismatches(seen, document), key="RAMP-PHASE-USED",
                     firmware_ok=not mismatches(seen, firmware), seen=f"set-points {seen[:12]}...")


@pytest.mark.req("CMD-SET-CONST", "FW-NUMBER-PARSER")
@pytest.mark.parametrize("token", ["0.25", "-1", ".5", "5.", "-.75", "+0.5", "0.0027777778", "123456789012",
                                   "1.23456789", "-0", "0.1", "30"])
def test_constant_setpoint_is_the_parsed_number(hat: HatUnderTest, motor_port: int, token: str) -> None:
    seen, _e, _t, reply = capture(hat, motor_port, f"set {token}", 3)
    accepted(reply)
    assert seen and all(close_to_printed(s, _n(token)) for s in seen), f"set {token}: set-points {seen}"


@pytest.mark.req("CMD-SET-CONST", "FW-NUMBER-PARSER", "FW-ERROR")
@pytest.mark.parametrize("line,sp,error", [("set 1e3", "1.00000", True), ("set .", OLD_SP, True),
                                           ("set -", OLD_SP, True), ("set", OLD_SP, True),
                                           ("set 0.5 0.3", "0.500000", True), ("set x", OLD_SP, True)])
def test_bad_numbers(hat: HatUnderTest, motor_port: int, line: str, sp: str, error: bool) -> None:
    start_quiet_pid(hat, motor_port, sp=OLD_SP)
    reply = hat.exchange(line)
    lines = pid_lines(hat.wait_for(lambda e: e.text.startswith(f"P{motor_port}: pv="), 3, 1000), motor_port)
    if error:
        rejected(reply)
    else:
        accepted(reply)
    want = f"{_n(sp):.5f}" if sp == OLD_SP else sp
    assert lines and lines[-1].sp == want, f"`{line}` left set-point {lines[-1].sp if lines else None}"


@pytest.mark.req("CMD-SET-SQUARE", "FW-SET-KEYWORDS")
@pytest.mark.parametrize("word", ["s", "sq", "si", "t", "tri", "p", "r", "v"])
def test_waveform_keywords_abbreviate_in_table_order(hat: HatUnderTest, motor_port: int, word: str) -> None:
    keywords = hat.set_keywords
    shape = next((k for k in keywords if k.startswith(word)), None)
    if shape == "var" or shape is None:
        reply = hat.exchange(f"port {motor_port} ; set {word} 0 1 0.2 0")
        # R1-R5 know no `var`; R6+ need an svar after the four numbers: Error either way.
        rejected(reply)
        return
    ticks = 25
    seen, _e, _t, reply = capture(hat, motor_port, f"set {word} 0.1 0.9 0.2 0", ticks)
    model = [v for v, _d in Generator(shape, _n("0.1"), _n("0.9"), _n("0.2"), 0).run(ticks)]
    accepted(reply)
    assert not mismatches(seen, model), f"`set {word}` is not {shape}: {seen[:8]}"


@pytest.mark.req("CMD-SET-SINE", "FW-SET-CLAMPS")
def test_period_and_phase_are_clamped(hat: HatUnderTest, motor_port: int) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-vectors: `set si -1 1 0.001 7` is a sine with T = 0.02 s and
    # phase 1.
    seen, _e, _t, reply = capture(hat, motor_port, "set si -1 1 0.001 7", 8)
    model = [v for v, _d in Generator("sine", -1, 1, 0.02, 1).run(8)]
    accepted(reply)
    assert not mismatches(seen, model), \
        f"expected a sine with T = 0.02 s and phase 1 (docs/FIRMWARE-BEHAVIOUR.md#fb-vectors), came {seen}"


@pytest.mark.req("CMD-SET-TRIANGLE", "FW-ERROR")
def test_bad_waveform_changes_nothing(hat: HatUnderTest, motor_port: int) -> None:
    seen, _e, _t, reply = capture(hat, motor_port, "set t 0 1 1e3 0", 3)
    assert reply.raw == b"\r\nError\r\n" and not seen, \
        "the generator must be unchanged (docs/FIRMWARE-BEHAVIOUR.md#fb-errors)"
    for line in ("set sine0 1 0.2 0", "set pulse 1 0 2", "set square 0 1 0.2"):
        rejected(hat.exchange(line))
