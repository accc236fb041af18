"""The HAT's TX ring, as far as the fuzzer must know it (FIRMWARE-FACTS §1, §6.2, §7.4).

Output leaves through an 8192-byte ring at the wire's pace (11.52 bytes/ms at 115200 baud); an
output byte written while the ring is full is dropped, silently. Data reports are held back
(not dropped) while the ring holds 4096 bytes or more, so reports alone keep at most that much
(and one report line) queued; the `debug` streams of DATA payloads (8) and PID lines (16) are
not held back and can fill the ring. Hence, on a wire:

- a step whose predicted output is longer than what the ring has room for (8192 less what the
  streams may hold) may come back with bytes missing, but never among the first bytes of its
  output (they always fit): :func:`headroom` says whether a step is at risk and from where;
- the fence must not be sent into a full ring (its answer would be lost): the runner lets the
  step's output drain first (:func:`drain_ms`), and appends `debug 0` to a line that would leave
  an unheld debug stream running (as it does for the raw serial trace of bit 1);
- such a step is judged by :func:`match_lossy`: what came must be the predicted answer with bytes
  missing only past the headroom, whole asynchronous lines between, and the fence's answer whole.
"""
from __future__ import annotations

import math
import re
from typing import List, Optional, Sequence

from ..harness.events import classify
from .expect import Expect
from .portmodel import PortModel
from .stream import ASYNC_KINDS, MatchResult, _match_item, match_stream

__all__ = ["RING_SIZE", "THROTTLE", "UNHELD_DEBUG", "headroom", "drain_ms", "match_lossy"]

RING_SIZE = 8192            # §1
THROTTLE = 4096             # §6.2: no report is printed while the ring holds this much
REPORT_LINE_MAX = 256       # a report line (held back as a whole, never cut) is shorter than this
FENCE_ROOM = 128            # the fence's answer (CRLF, the version line, a prompt) fits in this
WIRE_BYTES_PER_MS = 11.52   # 115200 baud, 8N1 (§1)
UNHELD_DEBUG = 8 | 16      # DATA payloads and PID lines: printed whatever the ring holds (§7.4)
_LIST_START = re.compile(rb"P[0-3]: |  ")   # how the lines of a `list` dump begin (§4.4)
_LIST_KINDS = ("list_port", "list_line")


def _backlog(states: Sequence[Sequence[PortModel]], debug: int, selrate_engine: bool) -> int:
    """The most the ring may hold, from what streams, when the step's output starts."""
    if debug & UNHELD_DEBUG:
        return RING_SIZE
    # A port whose state the model lost (a link change) may still report if a mode is selected.
    streaming = any(p.reporting(selrate_engine) or (not p.known and p.mode >= 0)
                    for ports in states for p in ports)
    return THROTTLE + REPORT_LINE_MAX if streaming else 0


def headroom(states: Sequence[Sequence[PortModel]], debug: int, selrate_engine: bool,
             size: int) -> Optional[int]:
    """The bytes of a step's output that always fit in the ring, when ``size`` (its predicted
    output) may not; None when all of it fits. ``debug``: the bits set before or after the step."""
    room = RING_SIZE - _backlog(states, debug, selrate_engine)
    return room if size > room else None


def drain_ms(size: int, sent: int, keep: int) -> int:
    """HAT ms to wait before the fence of a step that sends ``sent`` bytes and may print ``size``
    into a ring with room for ``keep``: its input must arrive, and enough must leave that the
    fence's answer fits (what reports add meanwhile is held back at 4096 bytes). A fifth more,
    and 10 ms, for a target that runs a little slower than the wire."""
    must_leave = max(0, size + FENCE_ROOM - keep)
    return math.ceil((sent + must_leave) / WIRE_BYTES_PER_MS * 1.2) + 10


def _fence_at(expected: Sequence[Expect]) -> Optional[int]:
    """Index of the fence's answer (its CRLF, then the version line): the last version line."""
    for i in range(len(expected) - 1, -1, -1):
        if expected[i].what == "version line":
            return i - 1 if i and expected[i - 1].what == "CRLF after CR" else i
    return None


def _async_line(actual: bytes, pos: int, allowed: frozenset):  # type: ignore[no-untyped-def]
    """The asynchronous event of the allowed line that starts at ``pos`` (None if there is none)."""
    end = actual.find(b"\r\n", pos)
    if end < 0:
        return None, pos
    ev = classify(actual[pos:end])
    if ev.kind in ASYNC_KINDS and ev.kind in allowed and ev.kind != "banner":
        return ev, end + 2
    return None, pos


def _listing_run(actual: bytes, pos: int, allowed: frozenset) -> int:
    """The end of the `list` dump lines from ``pos`` on, the last one perhaps cut by the ring,
    when a line printed once it drained follows right on (``pos`` when none starts here)."""
    while True:
        end = actual.find(b"\r\n", pos)
        if end < 0:
            return pos
        if classify(actual[pos:end]).kind in _LIST_KINDS:
            pos = end + 2
            continue
        if _LIST_START.match(actual, pos):
            for q in range(pos + 1, end):
                if _async_line(actual, q, allowed)[0] is not None:
                    return q
        return pos


def _lossy_walk(items: Sequence[Expect], actual: bytes, allowed: frozenset, keep: int,
                res: MatchResult) -> bool:
    """``actual`` is ``items`` with bytes missing only past the first ``keep`` bytes of output,
    with whole allowed asynchronous lines anywhere between (a line after a cut may follow its stub)."""
    i = j = pos = 0
    passed = 0          # bytes of output before this point: received, or predicted and missing
    while pos < len(actual):
        while i < len(items) and items[i].kind == "exact" and j >= len(items[i].data):
            i, j = i + 1, 0                       # (an item fully matched: on to the next)
        if i < len(items) and items[i].kind == "listing":
            # The dump first (its lines would pass as asynchronous: a connecting device prints
            # them too); whole, or cut short by the ring.
            end = _match_item(items[i], actual, pos) or _listing_run(actual, pos, allowed)
            if end > pos:
                passed, pos, i, j = passed + end - pos, end, i + 1, 0
                continue
        ev, nxt = _async_line(actual, pos, allowed)
        if ev is not None:
            res.asynchronous.append((i, ev))
            passed, pos = passed + nxt - pos, nxt
            continue
        while True:
            if i >= len(items):
                return False                      # output the prediction does not have
            item = items[i]
            if item.kind == "exact":
                if j >= len(item.data):
                    i, j = i + 1, 0
                    continue
                passed += 1
                j += 1
                if item.data[j - 1] == actual[pos]:
                    pos += 1
                    break
            else:
                end = _match_item(item, actual, pos)
                i, j = i + 1, 0
                if end is not None:
                    passed, pos = passed + end - pos, end
                    break
            if passed <= keep:
                return False                      # a byte missing where the ring had room
    left = sum(len(it.data) if it.kind == "exact" else 1 for it in items[i:]) - j
    return left <= 0 or passed >= keep


def match_lossy(expected: List[Expect], actual: bytes, allowed: frozenset,
                keep: int) -> Optional[MatchResult]:
    """The match of a step whose output may have met a full TX ring: None when what came is not
    the prediction with bytes missing as a full ring drops them (the caller then reports the
    strict match's problems)."""
    f = _fence_at(expected)
    if f is None:
        return None
    tail = b"".join(it.data for it in expected[f:f + 2] if it.kind == "exact")
    cut = actual.rfind(tail)
    if cut < 0:
        return None
    res = MatchResult()
    if not _lossy_walk(expected[:f], actual[:cut], allowed, keep, res):
        return None
    rest = match_stream(expected[f:], actual[cut:], allowed)
    if rest.problems:
        return None
    res.asynchronous += [(f + i, ev) for i, ev in rest.asynchronous]
    res.consumed = len(actual)
    return res
