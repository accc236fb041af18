"""Observations shared by the tests: PID debug lines, data lines, what a line ran.

Most commands print nothing; the suite watches their effect instead. A port in PID mode
with ``debug 16`` prints one line per 10 ms tick showing the set-point, so ``set``, ``on``,
``off``, ``pwm``, ``coast`` and ``pid`` all become visible on the wire
(docs/FIRMWARE-BEHAVIOUR.md#fb-debug-pid).
"""
from __future__ import annotations

import re
from typing import Any, List, Optional

from .hat_under_test import HatUnderTest
from .oracles.pid import PidLine, parse_pid_line

__all__ = ["MOTOR", "pid_lines", "start_quiet_pid", "pid_running", "data_lines", "DATA_LINE",
           "last_sp", "lines_of"]

#: The device most checks use: SPIKE Prime medium motor (Appendix C, 0x30).
MOTOR = 0x30
#: Its absolute-position mode: 1 x int16 (devices.json), data at any time.
APOS_MODE = 3

DATA_LINE = re.compile(r"P([0-3])(?:[MC][0-9]+|V):((?: +\S+)*)")


def lines_of(events: List[Any]) -> List[str]:
    return [e.text for e in events if getattr(e, "text", "")]


def pid_lines(events: List[Any], port: Optional[int] = None) -> List[PidLine]:
    out = []
    for text in lines_of(events):
        line = parse_pid_line(text)
        if line is not None and (port is None or line.port == port):
            out.append(line)
    return out


def data_lines(events: List[Any], port: int) -> List[str]:
    return [t for t in lines_of(events) if DATA_LINE.fullmatch(t) and int(t[1]) == port]


def start_quiet_pid(hat: HatUnderTest, port: int, sp: str = "0", mode: int = APOS_MODE, fmt: str = "s2",
                    scale: str = "0") -> None:
    """PID mode with zero gains (the motor is never driven) and ``debug 16`` on, so every
    tick prints its set-point. Needs an active device with data on ``port``."""
    pid = hat.pid_command(port, mode, 0, fmt, scale, "0", "0", "0", "0", "0", "0")
    replies = hat.setup(f"port {port} ; select {mode} ; {pid} ; set {sp} ; debug 16")
    assert not any(r.errors for r in replies), \
        f"setting up a quiet PID on port {port} failed: {b''.join(r.raw for r in replies)!r}"
    # PID lines start once the mode's data has arrived (docs/FIRMWARE-BEHAVIOUR.md#fb-pid).
    seen = hat.wait_for(lambda e: _is_pid(e, port), 2, 1000)
    assert pid_lines(seen, port), f"no PID debug lines on port {port} within 1 s of HAT time"


def _is_pid(event: Any, port: int) -> bool:
    line = parse_pid_line(getattr(event, "text", ""))
    return line is not None and line.port == port


def reports_after(hat: HatUnderTest, port: int, count: int = 2, max_hat_ms: float = 1500) -> List[Any]:
    """Events until ``count`` data reports of the selected mode on ``port`` arrived (every
    100 ms by default, docs/FIRMWARE-BEHAVIOUR.md#fb-reporting): proof that ~10 controller ticks
    passed, however slow the target, so "no PID line among them" means the controller really is
    not in PID mode."""
    return hat.wait_for(lambda e: bool(DATA_LINE.fullmatch(getattr(e, "text", "")))
                        and e.text[1] == str(port), count, max_hat_ms)


def pid_running(hat: HatUnderTest, port: int, hat_ms: float = 150) -> bool:
    return bool(pid_lines(hat.collect_ms(hat_ms), port))


def last_sp(hat: HatUnderTest, port: int, hat_ms: float = 120) -> Optional[str]:
    lines = pid_lines(hat.collect_ms(hat_ms), port)
    return lines[-1].sp if lines else None


class TickClock:
    """HAT time read from the HAT itself: with a quiet PID and ``debug 16`` on a motor port,
    each PID line is one 10 ms controller tick (docs/FIRMWARE-BEHAVIOUR.md#fb-controller), however
    fast or unevenly the target runs against the wall clock."""

    def __init__(self, hat: HatUnderTest, port: int):
        self.hat, self.port = hat, port
        self._pending: List[Any] = []          # events after the last window's end
        start_quiet_pid(hat, port)

    def _is_tick(self, event: Any) -> bool:
        return _is_pid(event, self.port)

    def run(self, hat_ms: float) -> List[Any]:
        """Every event during the next ``hat_ms`` of controller time: exactly that many ticks,
        the window cut at its last tick (output arrives in chunks that overshoot)."""
        ticks = max(1, round(hat_ms / 10))
        have = sum(1 for e in self._pending if self._is_tick(e))
        events = self._pending + (self.hat.wait_for(self._is_tick, ticks - have, hat_ms * 4 + 3000)
                                  if have < ticks else [])
        seen = 0
        for i, e in enumerate(events):
            if self._is_tick(e):
                seen += 1
                if seen == ticks:
                    self._pending = events[i + 1:]
                    return events[:i + 1]
        self._pending = []
        return events

    def include(self, events: List[Any]) -> None:
        """Events a test took from the link itself since the last window (a quick look at the
        first lines): they are counted in the next window, as if it had taken them."""
        self._pending = list(events) + self._pending

    def ticks_at(self, events: List[Any], text: str) -> List[int]:
        """For each line equal to ``text``: how many ticks came before it in ``events``."""
        out, ticks = [], 0
        for e in events:
            if self._is_tick(e):
                ticks += 1
            elif e.text == text:
                out.append(ticks)
        return out

    def count(self, events: List[Any]) -> int:
        return sum(1 for e in events if self._is_tick(e))
