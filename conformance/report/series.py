"""Numbers the report plots, taken from a transcript's command-port text alone (so they work
for hardware recordings too): ``debug 16`` PID lines and the ``set`` waveforms the host asked for.

The "ideal" waveform here is the continuous shape from the protocol document's parameters
(min, max, period, phase), not the firmware's table and float accumulator: the plot is there
to show how far the measured set-point is from what was asked.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Dict, Iterable, List, Optional

from ...harness.transcript import field_bytes

__all__ = ["PidSeries", "WaveRun", "pid_series", "wave_runs", "ideal_setpoint", "PID_LINE"]

PID_LINE = re.compile(r"^P([0-3]): pv=(\S+) sp=(\S+): e=(\S+) ie=(\S+) de=(\S+) cv=(\S+)$")
_SHAPES = ("square", "sine", "triangle", "pulse", "ramp")


def _num(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


@dataclass
class PidSeries:
    port: int
    t: List[float] = field(default_factory=list)
    pv: List[float] = field(default_factory=list)
    sp: List[float] = field(default_factory=list)
    e: List[float] = field(default_factory=list)
    ie: List[float] = field(default_factory=list)
    de: List[float] = field(default_factory=list)
    cv: List[float] = field(default_factory=list)


def pid_series(events: Iterable[dict]) -> Dict[int, PidSeries]:
    """Per port, every ``debug 16`` line: pv, sp, e, ie, de, cv against the line's time."""
    out: Dict[int, PidSeries] = {}
    for ev in events:
        if ev.get("dir") != "hat" or "line" not in ev:
            continue
        m = PID_LINE.match(ev["line"])
        if not m:
            continue
        port = int(m.group(1))
        s = out.setdefault(port, PidSeries(port))
        s.t.append(float(ev.get("t", 0)))
        for name, g in zip(("pv", "sp", "e", "ie", "de", "cv"), m.groups()[1:]):
            getattr(s, name).append(_num(g))
    return out


@dataclass
class WaveRun:
    """One ``set <shape> a b T phase`` on a port, from the time the host sent it."""

    port: int
    shape: str
    a: float
    b: float
    period: float   # seconds, clamped as the document's minimum (0.02 s)
    phase: float
    t0: float       # ms
    t_end: Optional[float] = None   # the next set-point command on the port, if any
    measured_t: List[float] = field(default_factory=list)
    measured_sp: List[float] = field(default_factory=list)


def ideal_setpoint(run: WaveRun, t_ms: float) -> float:
    """The continuous set-point the command describes, ``t_ms`` after the start of the transcript."""
    dt_ms = max(0.0, t_ms - run.t0)
    period_ms = run.period * 1000.0   # in ms, so round times give exact fractions
    if run.shape in ("pulse", "ramp") and dt_ms >= period_ms:
        return run.b
    phase = 0.0 if run.shape == "pulse" else run.phase
    x = (dt_ms / period_ms + phase) % 1.0
    if run.shape == "square":
        return run.b if x >= 0.5 else run.a
    if run.shape == "sine":
        return run.a + (run.b - run.a) * (math.sin(2 * math.pi * x) + 1) / 2
    if run.shape == "triangle":
        x = 1 - x if x >= 0.5 else x
        return run.a + (run.b - run.a) * 2 * x
    if run.shape == "pulse":
        return run.a
    return run.a + (run.b - run.a) * x


def _prefix_of(token: str, word: str) -> bool:
    return bool(token) and word.startswith(token)


def _floats(tokens: List[str]) -> Optional[List[float]]:
    try:
        return [float(t) for t in tokens]
    except ValueError:
        return None


def wave_runs(events: Iterable[dict]) -> List[WaveRun]:
    """The waveforms the host set, each with the ``sp`` values debug 16 measured for it.

    Tracks ``port N`` and ``set <shape> ...`` through abbreviations the way a reader of the
    transcript would; anything it does not understand ends the current line's scan."""
    events = list(events)
    runs: List[WaveRun] = []
    current: Dict[int, WaveRun] = {}
    port = 0
    for ev in events:
        if ev.get("dir") != "host":
            continue
        text = field_bytes(ev, "bytes").decode("latin-1")
        for line in text.split("\r"):
            toks = [t for t in re.split(r"[ ;]+", line) if t]
            i = 0
            while i < len(toks):
                tok = toks[i]
                if _prefix_of(tok, "port") and i + 1 < len(toks) and toks[i + 1].isdigit():
                    port, i = min(int(toks[i + 1]), 3), i + 2
                    continue
                if tok in ("s", "se", "set") and i + 1 < len(toks):
                    shape = next((s for s in _SHAPES if _prefix_of(toks[i + 1], s)), None)
                    if toks[i + 1] in ("s", "sq"):
                        shape = "square"
                    nums = _floats(toks[i + 2:i + 6]) if shape else _floats(toks[i + 1:i + 2])
                    if shape and nums and len(nums) == 4:
                        if port in current:
                            current[port].t_end = float(ev["t"])
                        run = WaveRun(port, shape, nums[0], nums[1], min(max(nums[2], 0.02), 1e30),
                                      min(max(nums[3], 0.0), 1.0), float(ev["t"]))
                        runs.append(run)
                        current[port] = run
                        i += 6
                        continue
                    if not shape and nums:   # a constant ends the waveform on this port
                        if port in current:
                            current[port].t_end = float(ev["t"])
                            del current[port]
                        i += 2
                        continue
                i += 1
    series = pid_series(events)
    for run in runs:
        s = series.get(run.port)
        if s is None:
            continue
        for t, sp in zip(s.t, s.sp):
            # A debug line stamped with the command's own millisecond was computed before the
            # command took effect (it shows the set-point before): not a sample of this wave.
            if t > run.t0 and (run.t_end is None or t < run.t_end):
                run.measured_t.append(t)
                run.measured_sp.append(sp)
    return runs
