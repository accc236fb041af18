"""Matching what a target printed against what the reference model predicted.

The model predicts the answer to the host's bytes as a list of :class:`~.model.Expect` items.
A HAT may also print asynchronous lines (device connects, data reports, debug output) between
any two of them; those are skipped here and handed back for the state and hygiene oracles.
Classification of lines is the harness's (``harness/events.py``), not ours.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from functools import lru_cache
from typing import List, Optional, Tuple

from ...harness.events import Event, classify, line_kind
from ...protocol.profiles import Profile
from ..model.expect import Expect
from .built_in import FATE, HYGIENE, LIVENESS, STATE
from .registry import Problem

__all__ = ["Problem", "MatchResult", "match_stream", "ASYNC_KINDS", "allowed_kinds", "split_lines",
           "without_torn"]

# Lines the firmware prints on its own (fb-async, fb-data, fb-debug); anything else must be predicted.
ASYNC_KINDS = frozenset({
    "mode_data", "combi_data", "var_data", "pid_debug", "data_debug", "signature_debug", "unknown_debug",
    "connecting", "baud", "established", "disconnected", "timeout", "checksum_error", "framing_error",
    "too_many_errors", "button", "pulse_done", "ramp_done", "port_fault", "motor_fault", "fault_dump",
    "fault_read_error", "mq_overrun", "deltat", "list_port", "connected_passive", "list_line", "i2c_error",
    "assertion", "banner",
})
_DEBUG_BIT = {"signature_debug": 4, "data_debug": 8, "pid_debug": 16, "unknown_debug": 32}
_LIST_HEADER = re.compile(rb"P([0-3]): (no device detected|connected to passive ID \d+|"
                          rb"connected to active ID [0-9A-F]{2})")


@dataclass
class MatchResult:
    asynchronous: List[Tuple[int, Event]] = field(default_factory=list)  # (expected index, event)
    problems: List[Problem] = field(default_factory=list)
    consumed: int = 0
    torn: List[Tuple[int, int]] = field(default_factory=list)   # async lines in an echo or after a prompt


def without_torn(actual: bytes, res: MatchResult) -> bytes:
    """``actual`` without the asynchronous lines that cut into an echo (the echo made whole)."""
    if not res.torn:
        return actual
    out, last = bytearray(), 0
    for start, end in res.torn:
        out += actual[last:start]
        last = end
    return bytes(out + actual[last:])


def allowed_kinds(profile: Profile, debug: Optional[int]) -> frozenset:
    """Asynchronous line kinds this release can print (fb-versions), given the debug bits (None: any)."""
    kinds = set(ASYNC_KINDS)
    if not profile.feature("button_events"):
        kinds.discard("button")
    if not profile.feature("disconnected_line"):
        kinds.discard("disconnected")
    if profile.feature("motor_fault_report") == "text_1hz":
        kinds -= {"fault_dump", "fault_read_error"}
    if debug is not None:
        kinds -= {k for k, bit in _DEBUG_BIT.items() if not debug & bit}
    return frozenset(kinds)


def split_lines(data: bytes) -> Tuple[List[bytes], bytes]:
    """Complete lines (without CRLF) and the unterminated rest."""
    parts = data.split(b"\r\n")
    return parts[:-1], parts[-1]


def _line_at(actual: bytes, pos: int) -> Optional[bytes]:
    end = actual.find(b"\r\n", pos)
    return None if end < 0 else actual[pos:end]


def _match_item(item: Expect, actual: bytes, pos: int) -> Optional[int]:
    """New position after ``item`` matched at ``pos``, or None."""
    if item.kind == "exact":
        return pos + len(item.data) if actual.startswith(item.data, pos) else None
    if item.kind == "pattern":
        line = _line_at(actual, pos)
        if line is None or not _compiled(item.pattern).fullmatch(line.decode("latin-1")):
            return None
        return pos + len(line) + 2
    # listing: a header for each port in order; an active device's block ends with its position PID
    for port in range(4):
        line = _line_at(actual, pos)
        m = _LIST_HEADER.fullmatch(line) if line is not None else None
        if line is None or m is None or int(m.group(1)) != port:
            return None
        pos += len(line) + 2
        if b"active" in m.group(2):
            while True:
                line = _line_at(actual, pos)
                if line is None or line_kind(line) != "list_line":
                    return None
                pos += len(line) + 2
                if line.startswith(b"  position PID:"):
                    break
    return pos


@lru_cache(maxsize=64)
def _compiled(pattern: str) -> re.Pattern:
    return re.compile(pattern)


def _show(data: bytes, limit: int = 120) -> str:
    return repr(data[:limit]) + ("..." if len(data) > limit else "")


def _asynchronous(res: MatchResult, idx: int, ev: Event, line: bytes, allowed: frozenset) -> None:
    res.asynchronous.append((idx, ev))
    if ev.kind == "banner":
        res.problems.append(LIVENESS.problem(f"start-up line {line!r}: the HAT rebooted"))
    elif ev.kind not in allowed:
        res.problems.append(HYGIENE.problem(f"{ev.kind} line {line!r} is not one this release "
                                            "prints in this state"))


# How far back from where the echo and the output part the cut may be: the echo's next bytes can be
# the first bytes of the line that cut it (`deltat=`, `P0M1: ` ...), a few at most.
_OVERLAP_MAX = 8


def _torn_echo(echo: bytes, actual: bytes, pos: int, idx: int, allowed: frozenset,
               res: MatchResult) -> Optional[int]:
    """The position after ``echo`` when asynchronous lines cut into it, else None.

    The echo leaves as the input arrives, byte by byte; on a paced wire input takes time, and a
    line the HAT prints meanwhile (a data report) lands between two echoed bytes. Such a line is
    skipped like any asynchronous line; anything else is a mismatch."""
    done, torn = 0, []
    while done < len(echo):
        n = len(os.path.commonprefix([echo[done:], actual[pos:pos + len(echo) - done]]))
        if n == 0 and not torn:
            return None              # not cut: it does not even start here
        if done + n == len(echo):
            done, pos = done + n, pos + n
            break
        # The line may begin with the byte the echo was due to send next (`...d(` cut by `deltat=`):
        # the common prefix then runs into the line, so the cut may be a few bytes further back.
        for back in range(min(n, _OVERLAP_MAX) + 1):
            line = _line_at(actual, pos + n - back)
            ev = classify(line) if line is not None else None
            if ev is not None and ev.kind in ASYNC_KINDS and (back < n or torn):
                break
        else:
            return None
        assert line is not None and ev is not None
        done, pos = done + n - back, pos + n - back
        torn.append((ev, line, pos))
        pos += len(line) + 2
    for ev, line, start in torn:
        _asynchronous(res, idx, ev, line, allowed)
        res.torn.append((start, start + len(line) + 2))
    return pos


def _torn_tail(echo: bytes, actual: bytes, pos: int, idx: int, allowed: frozenset,
               res: MatchResult) -> Optional[int]:
    """The position after ``echo`` when an asynchronous line cut it just before its last bytes and
    began with those very bytes (`...xP0` cut before `P0` by `P0M1: 5`), else None: the whole echo
    seemed to match, but the line goes on where the echo's CRLF was due."""
    for back in range(1, min(len(echo), _OVERLAP_MAX) + 1):
        start = pos + len(echo) - back
        end = actual.find(b"\r\n", start)
        tail = echo[len(echo) - back:]
        if end < 0 or not actual.startswith(tail, end + 2):
            continue
        line = actual[start:end]
        ev = classify(line)
        if ev.kind in ASYNC_KINDS:
            _asynchronous(res, idx, ev, line, allowed)
            res.torn.append((start, end + 2))
            return end + 2 + len(tail)
    return None


def match_stream(expected: List[Expect], actual: bytes, allowed: frozenset) -> MatchResult:
    """Walk ``expected`` over ``actual``, skipping asynchronous lines of ``allowed`` kinds."""
    res = MatchResult()
    pos = 0
    for idx in range(len(expected) + 1):
        item = expected[idx] if idx < len(expected) else None
        while True:
            if item is not None:
                if item.kind == "exact":      # inline: most items are (H10 profile)
                    nxt = pos + len(item.data) if actual.startswith(item.data, pos) else None
                    if nxt is not None and item.what == "echo" and actual[nxt:nxt + 2] not in (b"\r\n", b""):
                        nxt = _torn_tail(item.data, actual, pos, idx, allowed, res) or nxt
                else:
                    nxt = _match_item(item, actual, pos)
                if nxt is not None:
                    break
            if item is not None and item.what == "echo":
                nxt = _torn_echo(item.data, actual, pos, idx, allowed, res)
                if nxt is not None:
                    break
            line = _line_at(actual, pos)
            if line is None:
                break
            ev = classify(line)
            if ev.kind not in ASYNC_KINDS:
                break
            _asynchronous(res, idx, ev, line, allowed)
            if pos >= 2 and actual[pos - 2:pos] != b"\r\n":
                # Right after a prompt: the line comes apart from what follows it, for comparison.
                res.torn.append((pos, pos + len(line) + 2))
            pos += len(line) + 2
        if item is None:
            break
        if nxt is None:
            line = _line_at(actual, pos)
            kind = classify(line).kind if line is not None else None
            if line is not None and kind == "unknown" and not line.startswith(b"P"):
                oracle = HYGIENE.name
                what = f"an output line of no known class {line!r}"
            elif item.oracle == STATE.name and kind not in (None, "unknown"):
                # A whole line (Error, an answer) where the prompt or echo was due: the line's
                # fate is wrong, not the state the prompt shows.
                oracle = FATE.name
                what = _show(actual[pos:])
            else:
                oracle = item.oracle
                what = _show(actual[pos:])
            res.problems.append(Problem(oracle, f"expected {item.describe()}, got {what}", (idx, pos)))
            res.consumed = pos
            return res
        pos = nxt
    rest = actual[pos:]
    if rest:
        res.problems.append(HYGIENE.problem(f"unexpected trailing output {_show(rest)}",
                                            (len(expected), pos)))
    res.consumed = len(actual)
    return res
