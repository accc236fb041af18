"""Judging a step whose output may have met a full TX ring (fuzz/model/tx_ring.py,
docs/FIRMWARE-BEHAVIOUR.md#fb-tx-ring): what came must be the predicted answer with bytes missing, and
nothing else.

The answer is matched exactly from its start, skipping whole asynchronous lines, up to the first
byte that differs: there the ring dropped output, which it can only do past the bytes that always
fit (``keep``). The rest is matched from the end backwards, each byte that came against the latest
predicted byte it can be: once the ring is full, what gets through is what was written as it
drained, the later output. Lines the HAT prints once the ring drained (reports, stall lines) may
follow the stub of a cut line. While the ring stays full every byte that leaves frees one place,
which the next byte written takes: input echoed as it arrives (at the wire's pace too) gets most of
them, so what came is the prediction with many gaps, and a line the HAT prints by itself meanwhile
may leave a few of its bytes among them, in order: the stall line of the slow pass (the `help` that
filled the ring; sil findings: the `0` of `deltat=00000003` between two echoed bytes, its `d` after two
of help's), the end of a pulse or a ramp (`P3: pulse done`: its `P` inside an echo), and with
`debug 4` a port scan's signature line (its `P` between two echoed digits); at most one line of
each. A byte both the prediction and such a line can be is tried both ways. The fence's answer,
sent after the ring drained, must come whole.
"""
from __future__ import annotations

from bisect import bisect_left, bisect_right
from typing import Dict, List, Optional, Sequence, Tuple, Union

from ...harness.events import Event, classify
from ..model.expect import Expect
from .stream_match import ASYNC_KINDS, MatchResult, _compiled, _match_item, match_stream

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


# Lines a HAT prints by itself, never held back, that a slow pass may print into a full ring (the
# freed places go to whatever is written next): their bytes in order, a set of bytes per place. The
# stall line (fb-stall) of the pass that filled it; a passive-ID signature line (fb-debug, bit 4) of a
# port scan meanwhile; the end of a pulse or a ramp (fb-async). Longest forms: a line that came in
# part is a subsequence of one of them.
_HEX = frozenset(b"0123456789ABCDEF")


def _port_line(text: bytes) -> List[frozenset]:
    return [frozenset(b"P"), frozenset(b"0123")] + [frozenset((b,)) for b in text + b"\r\n"]


_STRAYS = {
    "pulse_done": _port_line(b": pulse done"),
    "ramp_done": _port_line(b": ramp done"),
    "deltat": [frozenset((b,)) for b in b"deltat="] + [_HEX] * 8 + [frozenset(b"\r"), frozenset(b"\n")],
    "signature_debug": ([frozenset(b"P"), frozenset(b"0123")] + [frozenset((b,)) for b in b": D5 signature="]
                        + [_HEX] * 4 + [frozenset((b,)) for b in b" id="] + [frozenset(b"0123456789")] * 2
                        + [frozenset(b"\r"), frozenset(b"\n")]),
}


def _stray_place(template: List[frozenset], left: int, byte: int) -> Optional[int]:
    """The latest place before ``left`` in a stray line's ``template`` that ``byte`` can be."""
    for j in range(left - 1, -1, -1):
        if byte in template[j]:
            return j
    return None


def _stray_start(stub: bytes, templates: List[List[frozenset]]) -> bool:
    """Whether ``stub`` is the start of a line a HAT prints by itself, whose rest the ring dropped
    (a line that came whole once it drained may follow it)."""
    return any(len(stub) <= len(t) and all(b in t[j] for j, b in enumerate(stub)) for t in templates)


class _Tokens:
    """The predicted tokens, indexed for the backward walk: the latest token before ``u`` that a
    byte can be is found without scanning every byte between."""

    def __init__(self, tokens: List[Token]):
        self.tokens = tokens
        self.by_byte: Dict[int, List[int]] = {}
        self.lines: List[int] = []               # pattern and listing items
        for k, (_i, tok) in enumerate(tokens):
            if isinstance(tok, int):
                self.by_byte.setdefault(tok, []).append(k)
            else:
                self.lines.append(k)

    def latest(self, byte: int, u: int, t0: int) -> int:
        """The latest byte token equal to ``byte`` in ``[t0, u)``, or ``t0 - 1``."""
        at = self.by_byte.get(byte, [])
        k = bisect_left(at, u) - 1
        return at[k] if k >= 0 and at[k] >= t0 else t0 - 1

    def lines_between(self, lo: int, u: int) -> List[int]:
        """Pattern and listing items in ``(lo, u)``, latest first."""
        a, b = bisect_right(self.lines, lo), bisect_left(self.lines, u)
        return self.lines[a:b][::-1]


# The places tried at most (a bound on a search that fails: such a step is a finding).
_SEARCH_MAX = 200_000
State = Tuple[int, int, Tuple[int, ...], Tuple[Tuple[int, Event], ...]]   # r, u, stray places left, async


def _predicted(idx: _Tokens, actual: bytes, start: int, r: int, u: int, t0: int,
               begin: Optional[int]) -> Optional[Tuple[int, int]]:
    """The prediction's reading of what ends at ``r``: (r, u) after the latest token it can be
    (tokens after it are lost), or None when no token before ``u`` can be it."""
    k = idx.latest(actual[r - 1], u, t0)
    for line in idx.lines_between(k, u):         # a line item later than that byte token first
        tok = idx.tokens[line][1]
        assert isinstance(tok, Expect)
        if tok.kind == "listing":
            return (_listing_back(actual, start, r) if begin is not None else r), line
        line_begin = _pattern_back(tok, actual, start, r)
        if line_begin is not None:
            return line_begin, line
    return (r - 1, k) if k >= t0 else None


def _backward(tokens: List[Token], t0: int, actual: bytes, start: int, allowed: frozenset,
              res: MatchResult) -> bool:
    """``actual[start:]`` is ``tokens[t0:]`` with some missing, and whole asynchronous lines
    (perhaps after the stub of a cut line) between, and bytes of at most one stray line of each
    kind (:data:`_STRAYS`) among them: matched from the end. A byte both readings allow is tried
    as the prediction's first, then as a stray line's (a search; the latest token a byte can be
    is the best choice for the prediction, so a place is tried again only with more left)."""
    idx = _Tokens(tokens)
    kinds = [k for k in _STRAYS if k in allowed]
    templates = [_STRAYS[k] for k in kinds]
    stack: List[State] = [(len(actual), len(tokens), tuple(len(t) for t in templates), ())]
    seen: Dict[Tuple[int, Tuple[int, ...]], int] = {}
    while stack:
        r, u, left, found = stack.pop()
        moved = True
        while r > start:
            if moved:
                if seen.get((r, left), -1) >= u or len(seen) > _SEARCH_MAX:
                    break                        # tried here with as much left, or more
                seen[(r, left)] = u
            begin = _line_before(actual, start, r)
            if begin is not None:
                ev = None
                for q in range(begin, r - 2):    # an asynchronous line, perhaps after a stub
                    ev = _async_at(actual, q, r - 2, allowed)
                    if ev is not None:
                        found, r = found + ((tokens[u - 1][0] if u else 0, ev),), q
                        # The stub may end in the start of a line a HAT prints by itself, its
                        # rest dropped by the ring: that part is no predicted output.
                        r = next((b for b in range(begin, q) if _stray_start(actual[b:q], templates)), q)
                        break
                if ev is not None:
                    moved = True
                    continue
            strays = [(r - 1, u, left[:n] + (j,) + left[n + 1:], found)
                      for n, template in enumerate(templates)
                      for j in (_stray_place(template, left[n], actual[r - 1]),) if j is not None]
            step = _predicted(idx, actual, start, r, u, t0, begin)
            if step is not None and strays and step[1] < u - 1:
                # The prediction's reading skips output (a gap) where a stray line's byte fits with
                # none: the stray first. (The other way round, a byte taken for the prompt a whole
                # line back sent the search through every digit a signature line could be.)
                stack.append((step[0], step[1], left, found))
                stack.extend(strays[1:])
                r, u, left, found = strays[0]
                moved = True
                continue
            stack.extend(strays)                 # pushed first: tried after the prediction
            if step is None:
                break
            moved = step[0] != r                 # (a `list` dump with none of its lines left: same place)
            r, u = step
        else:
            res.asynchronous.extend(found)
            return True
    return False


# The bytes a pattern line (fuzz/model/expect.py) is made of: what is left of one the ring cut holds no other.
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
