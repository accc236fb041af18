"""Judging a step whose output may have met a full TX ring (fuzz/txring.py, FIRMWARE-FACTS §1):
what came must be the predicted answer with bytes missing, and nothing else.

The answer is matched exactly from its start, skipping whole asynchronous lines, up to the first
byte that differs: there the ring dropped output, which it can only do past the bytes that always
fit (``keep``). The rest is matched from the end backwards, each byte that came against the latest
predicted byte it can be: once the ring is full, what gets through is what was written as it
drained, the later output. Lines the HAT prints once the ring drained (reports, stall lines) may
follow the stub of a cut line. While the ring stays full every byte that leaves frees one place,
which the next byte written takes: input echoed as it arrives (at the wire's pace too) gets most of
them, so what came is the prediction with many gaps, and the stall line a slow pass (the `help` that
filled the ring) prints by itself may leave a few of its bytes among them (a sil finding: `0` of
`deltat=00000003` between two echoed bytes); at most one such line's bytes are allowed there. The
fence's answer, sent after the ring drained, must come whole.
"""
from __future__ import annotations

from typing import List, Optional, Sequence, Tuple, Union

from ..harness.events import Event, classify
from .expect import Expect
from .stream import ASYNC_KINDS, MatchResult, _compiled, _match_item, match_stream

__all__ = ["match_lossy"]

_LIST_KINDS = ("list_port", "list_line")
Token = Tuple[int, Union[int, Expect]]      # (item index, one predicted byte, or a whole line item)


def _tokens(items: Sequence[Expect]) -> List[Token]:
    out: List[Token] = []
    for i, item in enumerate(items):
        if item.kind == "exact":
            out.extend((i, b) for b in item.data)
        else:
            out.append((i, item))
    return out


def _async_at(actual: bytes, pos: int, end: int, allowed: frozenset) -> Optional[Event]:
    """The allowed asynchronous line ``actual[pos:end]`` (``end`` at its CRLF), or None."""
    ev = classify(actual[pos:end])
    return ev if ev.kind in ASYNC_KINDS and ev.kind in allowed and ev.kind != "banner" else None


def _listing_run(actual: bytes, pos: int, allowed: frozenset) -> int:
    """The end of the `list` dump lines from ``pos`` on; the last may be cut after any byte,
    then a line printed once the ring drained follows right on (``pos``: none starts here)."""
    while True:
        end = actual.find(b"\r\n", pos)
        if end < 0:
            return pos
        if classify(actual[pos:end]).kind in _LIST_KINDS:
            pos = end + 2
            continue
        for q in range(pos + 1, end):
            if _async_at(actual, q, end, allowed) is not None:
                return q
        return pos


def _forward(tokens: List[Token], actual: bytes, allowed: frozenset,
             res: MatchResult) -> Tuple[int, int, int]:
    """Exact from the start: (tokens matched, bytes of ``actual`` used, output bytes passed)."""
    t = pos = passed = 0
    while pos < len(actual) and t < len(tokens):
        i, tok = tokens[t]
        if isinstance(tok, Expect) and tok.kind == "listing":
            # The dump first (its lines would pass as asynchronous: a connecting device prints
            # them too); whole, or cut short by the ring.
            end = _match_item(tok, actual, pos) or _listing_run(actual, pos, allowed)
            if end > pos:
                t, passed, pos = t + 1, passed + end - pos, end
                continue
        line_end = actual.find(b"\r\n", pos)
        ev = _async_at(actual, pos, line_end, allowed) if line_end >= 0 else None
        if ev is not None:
            res.asynchronous.append((i, ev))
            passed, pos = passed + line_end + 2 - pos, line_end + 2
            continue
        if isinstance(tok, int):
            if tok != actual[pos]:
                break
            t, pos, passed = t + 1, pos + 1, passed + 1
            continue
        end = _match_item(tok, actual, pos)
        if end is None:
            break
        t, passed, pos = t + 1, passed + end - pos, end
    return t, pos, passed


def _line_before(actual: bytes, start: int, r: int) -> Optional[int]:
    """Where the CRLF-terminated line that ends at ``r`` begins (not before ``start``)."""
    if r - 2 < start or actual[r - 2:r] != b"\r\n":
        return None
    begin = actual.rfind(b"\r\n", start, r - 2)
    return start if begin < 0 else begin + 2


# The stall line (fb-stall) a slow pass prints into a full ring: its bytes, and how many of them there are.
_STALL_BYTES = frozenset(b"deltat=0123456789ABCDEF\r\n")
_STALL_LINE = len(b"deltat=00000000\r\n")


def _backward(tokens: List[Token], t0: int, actual: bytes, start: int, allowed: frozenset,
              res: MatchResult) -> bool:
    """``actual[start:]`` is ``tokens[t0:]`` with some missing, and whole asynchronous lines
    (perhaps after the stub of a cut line) between, and at most a stall line's bytes: matched
    from the end."""
    r, u = len(actual), len(tokens)
    strays = _STALL_LINE if "deltat" in allowed else 0
    while r > start:
        begin = _line_before(actual, start, r)
        if begin is not None:
            skipped = False
            for q in range(begin, r - 2):          # an asynchronous line, perhaps after a stub
                ev = _async_at(actual, q, r - 2, allowed)
                if ev is not None:
                    res.asynchronous.append((tokens[u - 1][0] if u else 0, ev))
                    r, skipped = q, True
                    break
            if skipped:
                continue
        before = u
        while True:
            u -= 1
            if u < t0:
                if strays and actual[r - 1] in _STALL_BYTES:
                    strays, r, u = strays - 1, r - 1, before     # a byte of a stall line that got in
                    break
                return False                       # a byte the prediction does not have
            i, tok = tokens[u]
            if isinstance(tok, int):
                if tok == actual[r - 1]:
                    r -= 1
                    break
            elif tok.kind == "listing":
                if begin is not None:
                    r = _listing_back(actual, start, r)
                break
            else:
                line_begin = _pattern_back(tok, actual, start, r)
                if line_begin is not None:
                    r = line_begin
                    break
    return True


# The bytes a pattern line (fuzz/expect.py) is made of: what is left of one the ring cut holds no other.
_REPERTOIRE = {"vin": frozenset(b"0123456789. V"),
               "signature": frozenset(b"Firmwae signtu:0123456789ABCDEF")}


def _pattern_back(item: Expect, actual: bytes, start: int, r: int) -> Optional[int]:
    """Where a line of ``item``'s pattern that ends at ``r`` begins: whole, or what the ring left
    of it (its bytes only, and perhaps its CR or LF)."""
    begin = actual.rfind(b"\r\n", start, r - 1)
    begin = start if begin < 0 else begin + 2
    line = actual[begin:r]
    if line.endswith(b"\r\n"):
        body = line[:-2]
    else:
        body = line[:-1] if line.endswith((b"\r", b"\n")) else line
    if item.pattern and _compiled(item.pattern).fullmatch(body.decode("latin-1")):
        return begin
    allowed = _REPERTOIRE.get(item.what, frozenset())
    cut = len(body)
    while cut > 0 and body[cut - 1] in allowed:
        cut -= 1
    if cut < len(body) or len(body) < len(line):
        return r - (len(line) - cut)           # the cut line's last bytes (and its CR or LF)
    return None


def _listing_back(actual: bytes, start: int, r: int) -> int:
    """Back over `list` dump lines ending at ``r``."""
    while True:
        begin = _line_before(actual, start, r)
        if begin is None or classify(actual[begin:r - 2]).kind not in _LIST_KINDS:
            return r
        r = begin


def _fence_at(expected: Sequence[Expect]) -> Optional[int]:
    """Index of the fence's answer (its CRLF, then the version line): the last version line."""
    for i in range(len(expected) - 1, -1, -1):
        if expected[i].what == "version line":
            return i - 1 if i and expected[i - 1].what == "CRLF after CR" else i
    return None


def match_lossy(expected: List[Expect], actual: bytes, allowed: frozenset,
                keep: int) -> Optional[MatchResult]:
    """The match of a step whose output may have met a full TX ring: None when what came is not
    the prediction with bytes missing as a full ring drops them, past the first ``keep`` bytes
    (the caller then reports the exact match's problems)."""
    f = _fence_at(expected)
    if f is None:
        return None
    tail = b"".join(it.data for it in expected[f:f + 2] if it.kind == "exact")
    cut = actual.rfind(tail)
    if cut < 0:
        return None
    res = MatchResult()
    middle = actual[:cut]
    tokens = _tokens(expected[:f])
    t, pos, passed = _forward(tokens, middle, allowed, res)
    if t < len(tokens) and passed < keep:
        return None                                # a byte missing where the ring had room
    if pos < len(middle) and not _backward(tokens, t, middle, pos, allowed, res):
        return None
    rest = match_stream(expected[f:], actual[cut:], allowed)
    if rest.problems:
        return None
    res.asynchronous += [(f + i, ev) for i, ev in rest.asynchronous]
    res.consumed = len(actual)
    return res
