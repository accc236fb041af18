"""How to tell, from the wire, which command a token ran: one probe per command name.

Each probe sends ``token`` (plus arguments that suit the command it stands for) and answers
"did that command run?". Commands without output are recognised by their effect on a port
in PID mode with ``debug 16`` (set-point, lines stopping) or by their data reports, so a
probe can tell ``coast`` from ``clear_faults`` and ``off`` from ``on``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable, Dict

from .link import Hat, Reply
from .oracles.listing import parse_list
from .probes import TickClock, data_lines, pid_lines, reports_after, start_quiet_pid

__all__ = ["Outcome", "PROBES", "probe"]


@dataclass
class Outcome:
    ran: bool            # the probed command's own effect was seen
    error: bool          # the line printed Error
    seen: str            # what was observed, for messages


@dataclass
class Ctx:
    hat: Hat
    port: int            # a port with a motor (0x30) established
    can_data: bool       # the target can fix the motor's mode data (world @data)


def _reply(r: Reply, ran: bool) -> Outcome:
    return Outcome(ran and r.errors == 0, r.errors > 0, repr(r.raw[:160]))


def _exact(expected: Callable[[Hat], bytes]) -> Callable[[Ctx, str], Outcome]:
    def run(ctx: Ctx, token: str) -> Outcome:
        r = ctx.hat.exchange_quiet(token)
        return _reply(r, r.raw == expected(ctx.hat))
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


def _pid_like(differentiate: bool) -> Callable[[Ctx, str], Outcome]:
    """pid and pid_diff both start PID lines; with constant, non-zero data the process
    variable tells them apart (pid_diff differentiates it to 0, FACTS §7.2)."""
    def run(ctx: Ctx, token: str) -> Outcome:
        hat = ctx.hat
        if ctx.can_data:
            hat.world(f"@data {ctx.port} 3 64 00")        # APOS = 100
        try:
            hat.exchange(f"port {ctx.port} ; select 3 ; debug 16")
            # Let the @data message cross the wire before the first PID sample: a sample of the
            # old APOS followed by the new one gives one non-zero differentiated PV (§7.2).
            hat.collect_ms(20)
            args = hat.pid_command(ctx.port, 3, 0, "s2", "1", "0", "0", "0", "0", "0", "0").split(" ", 1)[1]
            r = hat.exchange(f"{token} {args}")
            lines = pid_lines(reports_after(hat, ctx.port, count=3), ctx.port)
        finally:
            if ctx.can_data:
                hat.world(f"@data {ctx.port} 3 auto")
        if not lines:
            return Outcome(False, r.errors > 0, f"{r.raw!r}; no PID lines")
        zero = all(ln.pv in ("0.00000", "-0.00000") for ln in lines[1:])
        ran = zero if differentiate else not zero
        return Outcome(ran and r.errors == 0, r.errors > 0, f"{r.raw!r}; pv {[ln.pv for ln in lines][:4]}")
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
    "help": _exact(lambda h: b"\r\n" + h.profile.help_bytes),
    "?": _exact(lambda h: b"\r\n" + h.profile.help_bytes),
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


def probe(hat: Hat, port: int, command: str, token: str) -> Outcome:
    """Run ``command``'s probe with ``token`` standing for the command name."""
    ctx = Ctx(hat, port, hat.can("data"))
    return PROBES[command](ctx, token)
