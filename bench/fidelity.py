"""Emulator timing fidelity at real time, seen from the host side of a real pty.

Each measurement opens the emulator target at speed 1, lets the firmware produce timed
output, and compares the arrival times of the lines (stamped by the session's reader
thread) with what the firmware does (FIRMWARE-BEHAVIOUR.md#fb-reporting: the report period;
#fb-setpoint: the ticks).
The figures include the pty and scheduling latency of this machine: that is what a host
library sees.
"""
from __future__ import annotations

import math
import statistics
from typing import Dict, List

from ..harness.session import Session
from ..harness.targets import open_target

# Real time, powered up before the host opens the port (start-up and device set-up are not what
# is measured, and took 2.5 s of every run at real time).
BOOTED = "emulator:latest?speed=1&booted=1"
# FIRMWARE-BEHAVIOUR.md#fb-setpoint: a pulse of T seconds ends after N ticks of 10 ms (float accumulation).
PULSE_TICKS = {0.5: 51, 1.0: 101}


def _session(url: str) -> Session:
    return Session(open_target(url)).open()


def wait_settled(s: Session, attempts: int = 100) -> None:
    """Wait (50 ms steps) until the emulator's layout is up, e.g. the default layout's motor on
    port 0 established before a ``select``."""
    control = s.target.control
    if control is None:
        raise ValueError(f"{s.target.url}: this benchmark needs an emulator target (a control channel)")
    for _ in range(attempts):
        if control.action("@settled").strip().endswith("1"):
            return
        s.wait_ms(50)


def report_period(url: str = BOOTED, seconds: float = 3.0, period_ms: int = 100) -> Dict:
    """Intervals between `P0M1:` report lines for `select 1` (period 100 ms on every release)."""
    s = _session(url)
    try:
        wait_settled(s)
        s.command("port 0 ; select 1")
        events = s.collect(seconds)
        s.command("select")
    finally:
        s.close()
    times = [e.t for e in events if e.kind == "mode_data"]
    gaps = [b - a for a, b in zip(times, times[1:])][1:]  # the first gap follows the SELECT
    if len(gaps) < 5:
        raise RuntimeError(f"only {len(gaps) + 1} reports in {seconds} s")
    errs = sorted(abs(g - period_ms) for g in gaps)
    return {"mean_ms": statistics.fmean(errs), "p99_ms": errs[min(len(errs) - 1, int(0.99 * len(errs)))],
            "n": len(gaps)}


def pulse_lateness(url: str = BOOTED, duration_s: float = 0.5, repeats: int = 3) -> Dict:
    """How late `P0: pulse done` arrives after `set pulse`, against the facts' tick count
    (the first tick is 0-10 ms after the command, so up to 10 ms early or late is inherent)."""
    expected_ms = PULSE_TICKS[duration_s] * 10.0
    s = _session(url)
    late: List[float] = []
    try:
        wait_settled(s)
        for _ in range(repeats):
            start = s.mark()
            t0 = s.now_ms()
            s.send(f"port 0 ; set pulse 0 0 {duration_s} 0")
            done = s.expect("pulse_done", timeout=duration_s * 4 + 2, since=start)
            late.append(done.t - t0 - expected_ms)
    finally:
        s.close()
    return {"mean_ms": statistics.fmean(late), "max_ms": max(late), "n": len(late)}


def waveform_period(url: str = BOOTED, period_s: float = 0.2,
                    seconds: float = 2.0) -> Dict:
    """Square-wave period measured from the drive changes seen in `debug 16` set-points.

    Uses a PID on the motor's SPEED with zero gains, so each 10 ms tick prints the set-point.
    """
    s = _session(url)
    try:
        wait_settled(s)
        eleven = s.profile is not None and s.profile.feature("pid_numbers") == 11
        pid = "pid 0 1 0 s1 1 0 0 0 0 0" + (" 0" if eleven else "")  # R6+: a deadzone too
        s.command(f"port 0 ; select 1 ; {pid} ; set square 0 1 {period_s} 0 ; debug 16")
        events = s.collect(seconds)
        s.command("debug 0 ; select ; pwm ; set 0")
    finally:
        s.close()
    rises = []
    last = None
    for e in events:
        if e.kind != "pid_debug":
            continue
        value = e.fields.get("sp")
        sp = float(value) if isinstance(value, (int, float)) else math.nan
        if last is not None and last < 0.5 <= sp:
            rises.append(e.t)
        last = sp
    periods = [b - a for a, b in zip(rises, rises[1:])]
    if len(periods) < 3:
        raise RuntimeError(f"only {len(rises)} rising edges seen")
    errs = [abs(p - period_s * 1000.0) for p in periods]
    return {"mean_ms": statistics.fmean(errs), "max_ms": max(errs), "n": len(periods)}
