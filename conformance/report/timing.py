"""Timing figures a report shows for a whole run, from its transcripts' command-port text:
the period between data lines of a port (``select``/``combi`` reporting), and how late each
``P<p>: pulse done`` / ``ramp done`` came after the period the host asked for.

The oracle is the protocol document's parameters (the period of a ``set pulse``/``set ramp``),
not the firmware's tick count: the figure shows the distance from what was asked."""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Dict, Iterable, List

from .series import wave_runs

__all__ = ["Timing", "collect_timing", "DATA_LINE"]

DATA_LINE = re.compile(r"^P([0-3])(?:M\d+|C\d+):")
_DONE = re.compile(r"^P([0-3]): (pulse|ramp) done$")
MAX_GAP_MS = 2000.0   # a longer gap is the stream stopping and starting again, not a period


@dataclass
class Timing:
    periods: List[float] = field(default_factory=list)          # ms between data lines of one port
    lateness: List[float] = field(default_factory=list)         # ms after t0 + period
    lateness_labels: List[str] = field(default_factory=list)    # "P0 pulse 0.1 s (test_x)"

    def add(self, events: Iterable[dict], label: str) -> None:
        events = list(events)
        last: Dict[int, float] = {}
        dones = False
        for ev in events:
            line = ev.get("line")
            if line is None or not line.startswith("P") or ev.get("dir") != "hat":
                continue
            m = DATA_LINE.match(line)
            if not m:
                dones = dones or bool(_DONE.match(line))
                continue
            port, t = int(m.group(1)), float(ev.get("t", 0))
            if port in last and 0 < t - last[port] <= MAX_GAP_MS:
                self.periods.append(t - last[port])
            last[port] = t
        if not dones:
            return        # no done line: no lateness to measure (and no waveform parsing to pay for)
        for run in wave_runs(events):
            if run.shape not in ("pulse", "ramp"):
                continue
            due = run.t0 + run.period * 1000.0
            for ev in events:
                m = _DONE.match(ev.get("line", "")) if ev.get("dir") == "hat" else None
                if m and int(m.group(1)) == run.port and m.group(2) == run.shape \
                        and float(ev.get("t", 0)) >= run.t0:
                    self.lateness.append(float(ev["t"]) - due)
                    self.lateness_labels.append(f"P{run.port} {run.shape} {run.period:g} s ({label})")
                    break


def collect_timing(transcripts: Iterable[tuple]) -> Timing:
    """``transcripts``: (path, label) pairs; unreadable files are left out."""
    from ...harness.transcript import iter_events

    timing = Timing()
    for path, label in transcripts:
        try:
            with open(path, encoding="utf-8") as fh:
                # Only events whose text holds "P can be a data, done or command line: the rest
                # (most of a transcript) is not decoded at all.
                timing.add(iter_events([raw for raw in fh if '"P' in raw or '"host"' in raw]), label)
        except (OSError, ValueError):
            continue
    return timing
