"""How to tell, from the wire, which command a token ran: one probe per command name.

Each probe sends ``token`` (plus arguments that suit the command it stands for) and answers
"did that command run?". Commands without output are recognised by their effect on a port
in PID mode with ``debug 16`` (set-point, lines stopping) or by their data reports, so a
probe can tell ``coast`` from ``clear_faults`` and ``off`` from ``on``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional

from .hat_under_test import HatUnderTest, Reply
from .mismatch import first_difference
from .oracles.listing import parse_list
from .probes import TickClock, data_lines, pid_lines, reports_after, start_quiet_pid

__all__ = ["Outcome", "PROBES", "probe", "pid_or_diff"]


@dataclass
class Outcome:
    ran: bool            # the probed command's own effect was seen
    error: bool          # the line printed Error
    seen: str            # what was observed, for messages


@dataclass
class Ctx:
    hat: HatUnderTest
    port: int            # a port with a motor (0x30) established


def _reply(r: Reply, ran: bool) -> Outcome:
    return Outcome(ran and r.errors == 0, r.errors > 0, repr(r.raw[:160]))


def _exact(expected: Callable[[HatUnderTest], bytes]) -> Callable[[Ctx, str], Outcome]:
    def run(ctx: Ctx, token: str) -> Outcome:
        r = ctx.hat.exchange_quiet(token)
        want = expected(ctx.hat)
        if r.raw == want or r.errors:
            return _reply(r, r.raw == want)
        # It answered, but not byte for byte: say where (conformance/mismatch.py).
        return Outcome(False, False, f"its answer differs at {first_difference(want, r.raw)}")
    return run


def _matches(pattern: bytes) -> Callable[[Ctx, str], Outcome]:
    def run(ctx: Ctx, token: str) -> Outcome:
        r = ctx.hat.exchange_quiet(token)
        return _reply(r, re.fullmatch(pattern, r.raw) is not None)
    return run


def _list(ctx: Ctx, token: str) -> Outcome:
    r = ctx.hat.exchange_quiet(token)
    try:
        parse_list(r.list_lines())
        ok = True
    except ValueError:
        ok = False
    return _reply(r, ok)


def _silent(args: str, undo: str = "") -> Callable[[Ctx, str], Outcome]:
    """A command that prints nothing: it ran if the line gave only its CRLF."""
    def run(ctx: Ctx, token: str) -> Outcome:
        r = ctx.hat.exchange(f"{token} {args}".strip())
        if undo:
            ctx.hat.exchange(undo)
        return _reply(r, r.raw == b"\r\n")
    return run


def _port(ctx: Ctx, token: str) -> Outcome:
    ctx.hat.exchange("echo 1")
    r = ctx.hat.exchange(f"{token} 2")
    ctx.hat.exchange("echo 0 ; port 0")
    return _reply(r, r.raw.endswith(b"P2>"))


def _echo(ctx: Ctx, token: str) -> Outcome:
    r = ctx.hat.exchange(f"{token} 1")
    ctx.hat.exchange("echo 0")
    return _reply(r, r.raw == b"\r\nP0>")


def _pid_effect(args: str, check: Callable[[list], bool], sp: str = "0.5") -> Callable[[Ctx, str], Outcome]:
    """Start a quiet PID on the motor port, send ``token args``, and look at the PID lines."""
    def run(ctx: Ctx, token: str) -> Outcome:
        start_quiet_pid(ctx.hat, ctx.port, sp=sp)
        r = ctx.hat.exchange(f"{token} {args}".strip())
        lines = pid_lines(reports_after(ctx.hat, ctx.port), ctx.port)
        return Outcome(check(lines) and r.errors == 0, r.errors > 0,
                       f"{r.raw!r}; PID lines after: {[ln.sp for ln in lines][:4]}")
    return run


def _sp(value: str) -> Callable[[list], bool]:
    return lambda lines: bool(lines) and all(ln.sp == value for ln in lines)


def _stopped(lines: list) -> bool:
    return not lines


def _still_running(lines: list) -> bool:
    return bool(lines) and all(ln.sp == "0.500000" for ln in lines)


def _debug(ctx: Ctx, token: str) -> Outcome:
    start_quiet_pid(ctx.hat, ctx.port)
    ctx.hat.exchange("debug 0")
    r = ctx.hat.exchange(f"{token} 16")
    return _reply(r, bool(pid_lines(reports_after(ctx.hat, ctx.port), ctx.port)))


def pid_or_diff(pvs: List[float], positions: List[float]) -> Optional[str]:
    """Which of pid / pid_diff produced these process values (scale 1 on APOS, whole degrees),
    given the positions the motor reported meanwhile; None when the values cannot tell.

    docs/FIRMWARE-BEHAVIOUR.md#fb-unwrap-r6: ``pid`` takes the position itself; ``pid_diff`` takes
    100 x its change per 10 ms tick, a multiple of 100, and 0 whenever the sensor did not change. A
    value is evidence for one of them only if the other could not have printed it: a position that
    is no multiple of 100 (a resting motor's jitter, or any angle but 0 and +-100) tells ``pid``; a
    multiple of 100 far from every reported position (the jitter's +-100, or 0 while the motor rests
    elsewhere) tells ``pid_diff``. A motor resting at exactly 0 (or +-100) without jitter gives
    neither: the caller moves it and looks again."""
    def like_position(pv: float) -> bool:
        return any(abs(pv - p) <= 2 for p in positions)

    def like_change(pv: float) -> bool:
        return abs(pv / 100 - round(pv / 100)) < 1e-6

    pid = any(like_position(pv) and not like_change(pv) for pv in pvs)
    diff = any(like_change(pv) and not like_position(pv) for pv in pvs)
    if pid != diff:
        return "pid" if pid else "diff"
    return None


def _nudge(hat: HatUnderTest, port: int) -> None:
    """Turn the motor a little (drive 0.4 for about two report periods, then coast about four)
    so it rests somewhere else. Timed by the HAT's own data reports, however fast it runs."""
    hat.exchange(f"port {port} ; select 3 ; pwm ; plimit 1 ; set 0.4")
    reports_after(hat, port, count=2)
    hat.exchange("coast")
    reports_after(hat, port, count=4)
    hat.exchange("plimit 0.1")           # the boot value (docs/FIRMWARE-BEHAVIOUR.md#fb-plimit)


def _pid_like(differentiate: bool) -> Callable[[Ctx, str], Outcome]:
    """pid and pid_diff both start PID lines; their process values tell them apart (see
    :func:`pid_or_diff`), read off the motor's own absolute position whatever it is: no
    world control needed, and a motor at rest on exactly 0 is moved until the values tell."""
    want = "diff" if differentiate else "pid"

    def run(ctx: Ctx, token: str) -> Outcome:
        hat = ctx.hat
        seen = ""
        for attempt in range(3):
            if attempt:
                _nudge(hat, ctx.port)
            hat.exchange(f"port {ctx.port} ; select 3 ; debug 16")
            args = hat.pid_command(ctx.port, 3, 0, "s2", "1", "0", "0", "0", "0", "0", "0").split(" ", 1)[1]
            r = hat.exchange(f"{token} {args}")
            events = r.events + reports_after(hat, ctx.port, count=3)
            lines = pid_lines(events, ctx.port)
            if not lines:
                return Outcome(False, r.errors > 0, f"{r.raw!r}; no PID lines")
            # The first sample after pid/pid_diff is the position for both on R1-R5 and for pid,
            # 0 for pid_diff (docs/FIRMWARE-BEHAVIOUR.md#fb-unwrap-r1, #fb-unwrap-r6): fine either
            # way, but skip it so a stale line cannot mislead.
            pvs = [ln.value("pv") for ln in lines[1:]]
            positions = [float(v) for t in data_lines(events, ctx.port) if t.startswith(f"P{ctx.port}M3:")
                         for v in t.split(":", 1)[1].split()[:1]]
            seen = f"{r.raw!r}; pv {[ln.pv for ln in lines][:6]}, positions {positions[:6]}"
            told = pid_or_diff(pvs, positions)
            if told is not None:
                return Outcome(told == want and r.errors == 0, r.errors > 0, seen)
        return Outcome(False, False, f"cannot tell pid from pid_diff after moving the motor twice: {seen}")
    return run


def _select(count_ok: Callable[[int], bool], mode: int = 1) -> Callable[[Ctx, str], Outcome]:
    def run(ctx: Ctx, token: str) -> Outcome:
        ctx.hat.exchange(f"port {ctx.port}")
        r = ctx.hat.exchange(f"{token} {mode}")
        head = f"P{ctx.port}M{mode}:"
        # R5+ print a selonce report at once, so it may already be in the reply; wait for
        # the first one (a slow target must not look like "no report"), then look a while.
        events = r.events + ctx.hat.wait_for(lambda e: e.text.startswith(head), 1, 1500)
        events += ctx.hat.collect_ms(450)
        n = len([ln for ln in data_lines(events, ctx.port) if ln.startswith(head)])
        ctx.hat.exchange("select ; port 0")
        return Outcome(count_ok(n) and r.errors == 0, r.errors > 0, f"{r.raw!r}; {n} data lines in 450 ms")
    return run


def _selrate(ctx: Ctx, token: str) -> Outcome:
    """selrate changes how often the selected mode is reported: count reports against the
    controller's own 10 ms ticks (a quiet PID on mode 3 keeps ticking on its last data)."""
    hat = ctx.hat
    clock = TickClock(hat, ctx.port)
    hat.exchange(f"port {ctx.port} ; select 1")
    clock.run(150)
    r = hat.exchange(f"{token} 20")
    clock.run(50)
    n = len([ln for ln in data_lines(clock.run(300), ctx.port) if ln.startswith(f"P{ctx.port}M1:")])
    hat.exchange("select ; debug 0 ; port 0")
    return Outcome(n >= 8 and r.errors == 0, r.errors > 0, f"{r.raw!r}; {n} reports in 30 ticks")


PROBES: Dict[str, Callable[[Ctx, str], Outcome]] = {
    "help": _exact(lambda h: b"\r\n" + h.help_bytes),
    "?": _exact(lambda h: b"\r\n" + h.help_bytes),
    "version": _matches(rb"\r\nFirmware version: [^\r\n]+\r\n"),
    "vin": _matches(rb"\r\n[0-9]+\.[0-9]{2} V\r\n"),
    "signature": _matches(rb"\r\nFirmware signature:( [0-9A-F]{2}){64}\r\n"),
    "list": _list,
    "port": _port,
    "echo": _echo,
    "ledmode": _silent("2", undo="ledmode -1"),
    "debug": _debug,
    "clear_faults": _pid_effect("", _still_running),
    "coast": _pid_effect("", _stopped),
    "pwm": _pid_effect("", _stopped),
    "set": _pid_effect("0.25", _sp("0.250000")),
    "off": _pid_effect("", _sp("0.00000")),
    "on": _pid_effect("", _sp("1.00000")),
    "pid": _pid_like(differentiate=False),
    "pid_diff": _pid_like(differentiate=True),
    "bias": _silent("0.2", undo="bias 0"),
    "pwmparams": _silent("0 0"),
    "plimit": _silent("0.1"),
    "port_plimit": _silent("0.1"),
    "select": _select(lambda n: n >= 3),
    "selonce": _select(lambda n: n == 1),
    "selrate": _selrate,
    "combi": _silent("7 1 0", undo="combi 7"),
    "write1": _silent("c0"),
    "write2": _silent("c0 00 00"),
}


def probe(hat: HatUnderTest, port: int, command: str, token: str) -> Outcome:
    """Run ``command``'s probe with ``token`` standing for the command name."""
    ctx = Ctx(hat, port)
    return PROBES[command](ctx, token)
