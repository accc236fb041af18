"""One scenario on two HATs with the same world, compared line by line and by time.

The emulator is measured against the firmware in the loop (``sil:<tree>``) by running the same
script on both from power-on (issue 37): each side boots (scenario time 0 is where its boot
ends, the same rule on every target), then the walk of :func:`walk_actions` runs the script,
reading the HAT every millisecond. A line's time is the millisecond in which its last byte
came: the same clock on both sides, finer than a session's reads, which a virtual target may
batch.

:func:`compare` pairs the lines in order. A pair is *equal* when the text is; it is *in time*
when the two times are within the tolerance: the stated ±1 ms, plus the wire's byte time for a
line whose length differs (only when the text does). What may differ for a stated reason is
data a device sends (its noise: APOS flicker, a data report's values) unless the script fixes
it with ``@data``; the caller says which lines those are (``noise``, a regular expression).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Pattern, Protocol, Tuple

from .script import Script
from .script_runner import TAIL_MS, walk_actions

__all__ = ["HatLike", "Line", "run_lines", "compare", "Comparison", "TOLERANCE_MS", "DATA_LINE"]

TOLERANCE_MS = 1
BYTE_MS = 10 * 1000 / 115200          # one byte on the HAT's wire (8N1 at 115200 baud)
# A device's own data as the HAT prints it: reports (`P0C0: ...`, `P1M2: ...`) and the PID's debug
# line, whose process variable is the device's data.
DATA_LINE = re.compile(r"^P[0-3](?:C[0-9]|M[0-9]+): |^P[0-3]: pv=")

Line = Tuple[int, str]


class HatLike(Protocol):
    """What is needed of a HAT model (the emulator's ``Emulator``, the firmware in the loop's
    ``SilHat``): virtual milliseconds, bytes both ways, world actions."""

    @property
    def now(self) -> int: ...
    def boot(self) -> int: ...
    def advance(self, ms: int) -> None: ...
    def write(self, data: bytes) -> None: ...
    def read(self) -> bytes: ...
    def world(self, line: str) -> str: ...


class _MsDriver:
    """The walk's driver: one millisecond at a time, every line timed by its last byte."""

    def __init__(self, hat: HatLike):
        self.hat = hat
        self.origin = hat.now
        self.lines: List[Line] = []
        self._partial = bytearray()

    def now(self) -> float:
        return float(self.hat.now - self.origin)

    def _take(self) -> None:
        data = self.hat.read()
        if not data:
            return
        t = self.hat.now - self.origin
        self._partial += data
        while b"\n" in self._partial:
            line, _, rest = bytes(self._partial).partition(b"\n")
            self._partial = bytearray(rest)
            self.lines.append((t, line.rstrip(b"\r").decode("latin-1")))

    def wait_until(self, t_ms: float) -> None:
        while self.now() < t_ms:
            self.hat.advance(1)
            self._take()

    def send(self, data: bytes) -> None:
        self.hat.write(data)

    def world(self, text: str) -> None:
        self.hat.world(text)


def run_lines(hat: HatLike, script: Script, end_ms: Optional[float] = None, boot: bool = True) -> List[Line]:
    """Boot ``hat`` (made with the script's layout), drop what it printed while nobody listened,
    walk the script and return its lines with their times (ms since scenario time 0). With
    ``boot=False`` the script starts at power-on and the start-up is part of it."""
    if boot:
        hat.boot()
        hat.read()
    driver = _MsDriver(hat)
    walk_actions(script, driver, end_ms)
    driver.wait_until(driver.now() + TAIL_MS)       # what a line's last bytes still carry
    if driver._partial:
        driver.lines.append((int(driver.now()), bytes(driver._partial).decode("latin-1")))
    return driver.lines


_BYTES_PER_MS = 1 / BYTE_MS


def _cut_alike(x: Line, y: Line, tolerance_ms: float) -> bool:
    """The run's last line, unfinished on both sides: one a prefix of the other, the bytes
    between them no more than the wire carries in the tolerance."""
    short, long_ = sorted((x[1], y[1]), key=len)
    return (long_.startswith(short) and abs(x[0] - y[0]) <= tolerance_ms
            and len(long_) - len(short) <= (tolerance_ms + 1) * _BYTES_PER_MS)


def _moved_within(a: List[Line], b: List[Line], i: int, tolerance_ms: float) -> bool:
    """Lines ``i`` and ``i+1`` (or ``i-1`` and ``i``) hold the same bytes on both sides, a line
    that came while another was being echoed sitting a few bytes apart (within what the wire
    carries in the tolerance), each pair within the tolerance in time."""
    for j in (i, i - 1):
        if j < 0 or j + 1 >= min(len(a), len(b)):
            continue
        xa, xb, ya, yb = a[j], a[j + 1], b[j], b[j + 1]
        if xa[1] == ya[1] and xb[1] == yb[1]:
            continue
        if sorted(xa[1] + xb[1]) != sorted(ya[1] + yb[1]):
            continue
        if abs(len(xa[1]) - len(ya[1])) > (tolerance_ms + 1) * _BYTES_PER_MS:
            continue
        if abs(xa[0] - ya[0]) <= tolerance_ms and abs(xb[0] - yb[0]) <= tolerance_ms:
            return True
    return False


def _same_kind(noise: Pattern[str], x: str, y: str) -> bool:
    """Both lines are device data of the same kind (the pattern's match is the same text:
    ``P0C0: `` with ``P0C0: ``, a port's PID line with the same port's)."""
    mx, my = noise.search(x), noise.search(y)
    return mx is not None and my is not None and mx.group(0) == my.group(0)


@dataclass
class Comparison:
    """Two runs' lines compared (``a`` the reference, e.g. the firmware; ``b`` the other)."""

    pairs: int = 0
    equal: int = 0
    in_time: int = 0               # equal lines within the tolerance
    noise: int = 0                 # differing lines the caller's noise pattern explains
    cut: int = 0                   # the last line, cut by the run's end within a ms of bytes
    moved: int = 0                 # lines with another's bytes inside at a place a ms apart
    differences: List[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.differences

    def summary(self) -> str:
        return (f"{self.pairs} lines: {self.equal} equal, {self.in_time} within {TOLERANCE_MS} ms"
                f"{f', {self.noise} device data' if self.noise else ''}"
                f"{f', {self.cut} cut by the end' if self.cut else ''}"
                f"{f', {self.moved} a few bytes apart' if self.moved else ''}"
                f"{f'; {len(self.differences)} differ' if self.differences else ''}")


def compare(a: List[Line], b: List[Line], tolerance_ms: float = TOLERANCE_MS,
            noise: Optional[Pattern[str]] = None,
            explain: Callable[[Line, Line], Optional[str]] = lambda x, y: None) -> Comparison:
    """Pair the lines in order; a pair that differs in text (and is no device noise) or in time
    (beyond ``tolerance_ms``, plus the wire's byte time for a length difference) is a
    difference, said in one line. ``explain`` may name a stated reason for a pair (kept out of
    the differences)."""
    out = Comparison(pairs=max(len(a), len(b)))
    for i in range(out.pairs):
        if i >= len(a) or i >= len(b):
            side, only = ("a", a[i]) if i < len(a) else ("b", b[i])
            out.differences.append(f"line {i + 1}: only on {side}: t={only[0]} {only[1]!r}")
            continue
        x, y = a[i], b[i]
        if i == out.pairs - 1 and x[1] != y[1] and _cut_alike(x, y, tolerance_ms):
            out.cut += 1               # the run's end cut the last line a few bytes apart
            continue
        if _moved_within(a, b, i, tolerance_ms):
            out.moved += 1             # a line that landed a few bytes apart inside another
            continue
        same = x[1] == y[1]
        slack = tolerance_ms + abs(len(x[1]) - len(y[1])) * BYTE_MS
        timely = abs(x[0] - y[0]) <= slack
        if same:
            out.equal += 1
            out.in_time += timely
        if same and timely:
            continue
        if not same and noise is not None and timely and _same_kind(noise, x[1], y[1]):
            out.noise += 1
            continue
        reason = explain(x, y)
        if reason is not None:
            continue
        out.differences.append(f"line {i + 1}: t={x[0]} {x[1]!r} / t={y[0]} {y[1]!r}")
    return out
