"""Differential comparison: the same input's answers from two targets.

What must match exactly: every line a command printed in answer (its class and text), the
``Error`` lines, prompts and echo. What is compared with tolerance: analogue readings (``vin``
within :data:`VIN_TOLERANCE_V`; numbers in data reports within :data:`VALUE_TOLERANCE`).
What is not compared: asynchronous lines (reports, connects, debug), because their number and
position depend on timing; each side's own hygiene and state oracles judge them. Nor, once the
sides part on it, the `list` block of a port with the light matrix (:func:`parted_matrix`). A connect
dump (asynchronous) whose first lines a read took with the last answer is whole again in front of the
next (:func:`open_dump`).
"""
from __future__ import annotations

import math
import re
from functools import lru_cache
from typing import FrozenSet, List, Optional, Tuple

from ...harness.events import PORT_STATUS_KINDS, Event, classify, line_kind
from .stream_match import ASYNC_KINDS

__all__ = ["compare_answers", "first_difference", "VIN_TOLERANCE_V", "VALUE_TOLERANCE", "synchronous_part",
           "parted_matrix", "MATRIX_ID", "open_dump", "sync_bytes_before"]

VIN_TOLERANCE_V = 0.10
VALUE_TOLERANCE = 0.05      # relative, for positions/speeds in data lines
MATRIX_ID = 0x40            # the 3x3 light matrix: it stops talking after a while without motor power


_PROMPTS = re.compile(rb"((?:P[0-3]>)+)(.+)", re.S)


def _prompts_apart(parts: List[bytes]) -> List[bytes]:
    """A line the HAT printed by itself right after a prompt (``P0>P0V: ...``) comes apart from
    it; the prompt goes with the next line (the echo it would have preceded)."""
    out: List[bytes] = []
    carry = b""
    for i, raw in enumerate(parts):
        raw = carry + raw
        carry = b""
        m = _PROMPTS.fullmatch(raw)
        if m and i < len(parts) - 1 and line_kind(m.group(2)) in ASYNC_KINDS:
            out.append(m.group(2))
            carry = m.group(1)
            continue
        out.append(raw)
    if carry:
        out.append(carry)
    return out


# Where a line the HAT prints by itself can start: a port's report or event, or one of the lines without
# a port (the main loop's stall line after a slow pass, fb-stall; a queue overrun; the power faults).
_GLUED = re.compile(rb"(?=P[0-3](?:M[0-9]|C[0-9]|V|: )|deltat=|MQ overrun!|(?:Port|Motor) power fault)")


def _glued_at(raw: bytes) -> Optional[int]:
    """Where in ``raw`` (not at its start) a line the HAT printed by itself begins: the first place
    whose rest is such a line. Echoed bytes may look like the start of one (`P1: ` in a noise line)
    before the real cut, so each candidate is tried in turn."""
    for m in _GLUED.finditer(raw, 1):
        if line_kind(raw[m.start():]) in ASYNC_KINDS:
            return m.start()
    return None


def _torn_apart(parts: List[bytes]) -> List[bytes]:
    """A line the HAT printed by itself while an echo was still arriving (``P0>abcP0V: 1.0``, then
    ``def`` as the next piece; or ``P0>abcdeltat=00000003`` after a slow pass, whose end comes
    while the line's bytes are still crossing the wire) comes apart from it and the echo is made
    whole (``P0>abcdef``):
    where input crosses a wire the report lands between two echoed bytes, on either side at its own
    instant. (Each side's stream oracle does the same when its model knows the echo; this is for
    the comparison, also on a step the model cannot follow.)"""
    out: List[bytes] = []
    i = 0
    while i < len(parts):
        raw = parts[i]
        at = (_glued_at(raw) if i < len(parts) - 1 and _GLUED.search(raw, 1) is not None
              and line_kind(raw) not in ASYNC_KINDS else None)
        if at is not None:
            out.append(raw[at:])
            parts = parts[:i + 1] + [raw[:at] + parts[i + 1]] + parts[i + 2:]
            i += 1
            continue
        out.append(raw)
        i += 1
    return out


def synchronous_part(data: bytes) -> Tuple[List[bytes], List[Event]]:
    """(pieces that answer commands, asynchronous events). Pieces are complete lines, or the
    unterminated rest (a prompt). Listing lines answer `list`, except the device dump a HAT
    prints on connecting (fb-active): one port's header and block, then that port's ``established``
    line. Its time depends on each target's clock, so it is not compared."""
    sync, async_events = _split(data)
    return list(sync), list(async_events)


@lru_cache(maxsize=16)
def _split(data: bytes) -> Tuple[Tuple[bytes, ...], Tuple[Event, ...]]:
    """:func:`synchronous_part`, kept for the last few answers: one step's answer is split for
    the connection tracker and again for each comparison of the differential oracle."""
    parts = _torn_apart(_prompts_apart(data.split(b"\r\n")))
    sync: List[bytes] = []
    async_events: List[Event] = []
    block: List[Tuple[bytes, str]] = []       # listing lines since the last other line, and their kinds
    # (kinds come from the cached line_kind; an Event is made only for a line that needs one:
    # the campaign's hottest path was classifying every line of every long `list` twice)
    for i, raw in enumerate(parts):
        last = i == len(parts) - 1
        if last and not raw:
            continue
        kind = line_kind(raw)
        if not last and kind in ("list_line", "list_port"):
            block.append((raw + b"\r\n", kind))
            continue
        dump = 0
        if kind == "established":
            port = classify(raw).port
            headers = [k for k, (_p, kd) in enumerate(block) if kd == "list_port"]
            if headers and classify(block[headers[-1]][0][:-2]).port == port:
                dump = len(block) - headers[-1]
        if block:
            sync.extend(p for p, _k in block[:len(block) - dump])
            async_events.extend(classify(p[:-2]) for p, _k in block[len(block) - dump:])
            block = []
        if not last and kind in ASYNC_KINDS:
            async_events.append(classify(raw))
            continue
        sync.append(raw + (b"" if last else b"\r\n"))
    sync.extend(p for p, _k in block)
    return tuple(sync), tuple(async_events)


_LEADING_PROMPTS = re.compile(rb"(?:P[0-3]>)*")


def open_dump(data: bytes) -> bytes:
    """The connect dump ``data`` (output no command answers: what came after a fence's answer, or
    during a wait) ends inside of: its lines from the port's header on, else b"".

    On a wire the dump a HAT prints when a device's set-up ends (fb-active: ``set baud rate``, the
    dump, ``established``; ~1 KB) takes ~90 ms to cross; a read that stops at the fence's answer
    takes its first lines, and the next step's answer begins with the rest, which without its
    header reads as a `list` answer (a sil finding). The comparison of the next step puts these
    lines back in front of it (fuzz/running/checked_run.py)."""
    if b"connected to active ID" not in data:       # (most reads: no dump's header, nothing to split)
        return b""
    lines = data.split(b"\r\n")[:-1]          # (a line still arriving is the link's carry-over)
    for i in range(len(lines) - 1, -1, -1):
        line = _LEADING_PROMPTS.sub(b"", lines[i], count=1)     # (its first match is at the start)
        kind = line_kind(line)
        if kind == "established":
            return b""
        if kind == "list_port" and classify(line).fields.get("state") == "active":
            return b"".join(raw + b"\r\n" for raw in [line] + lines[i + 1:])
    return b""


def _close(a: Event, b: Event) -> bool:
    if a.kind != b.kind:
        return False
    if a.kind == "vin":
        va, vb = a.fields["volts"], b.fields["volts"]
        assert isinstance(va, float) and isinstance(vb, float)      # the vin row's parser
        return abs(va - vb) <= VIN_TOLERANCE_V + 1e-9
    if a.kind in ("mode_data", "combi_data"):
        va, vb = a.fields.get("values", []), b.fields.get("values", [])
        assert isinstance(va, list) and isinstance(vb, list)        # the data rows' parser
        return len(va) == len(vb) and all(_num_close(x, y) for x, y in zip(va, vb))
    return a.raw == b.raw


def _num_close(x: float, y: float) -> bool:
    if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
        return True
    return abs(x - y) <= max(1.0, VALUE_TOLERANCE * max(abs(x), abs(y)))


def parted_matrix(pa: Optional[bytes], pb: Optional[bytes]) -> Optional[int]:
    """The port whose light matrix one side lists and the other no longer does, else None.

    The matrix stops talking once its port has had no motor drive for longer than a grace (a
    device-model choice, emulator/devices/matrix.py). Two targets' HAT clocks run apart (the
    firmware in the loop prints through a 115200-baud wire, the emulator unpaced at once), so a
    drive cut that one side restores just inside the grace the other restores just outside it;
    that side's matrix is gone until it is plugged in again. A timing boundary, not a behaviour."""
    if pa is None or pb is None:
        return None
    ea, eb = classify(pa.rstrip(b"\r\n")), classify(pb.rstrip(b"\r\n"))
    if ea.kind != "list_port" or eb.kind != "list_port" or ea.port != eb.port:
        return None
    states = {ea.fields.get("state"), eb.fields.get("state")}
    ids = {ea.fields.get("id"), eb.fields.get("id")} - {None}
    return ea.port if states == {"none", "active"} and ids == {MATRIX_ID} else None


_IDENTITY_KINDS = frozenset({"version", "signature", "help"})


def _without_identity(pieces: List[bytes], identity: FrozenSet[bytes]) -> List[bytes]:
    """``pieces`` without the lines that name a build (``identity``: its help texts; and every
    `version` and `signature` line); all of them when ``identity`` is empty (the same build)."""
    if not identity:
        return pieces
    return [p for p in pieces if p.rstrip(b"\r\n") not in identity
            and line_kind(p.rstrip(b"\r\n")) not in _IDENTITY_KINDS]


def _without_ports(pieces: List[bytes], ports: FrozenSet[int]) -> List[bytes]:
    """``pieces`` without the `list` blocks (a port's header and its lines) of ``ports``."""
    if not ports:
        return pieces
    out: List[bytes] = []
    skipping = False
    for piece in pieces:
        kind = line_kind(piece.rstrip(b"\r\n"))
        if kind in PORT_STATUS_KINDS:
            skipping = classify(piece.rstrip(b"\r\n")).port in ports
        elif kind != "list_line":
            skipping = False
        if not skipping:
            out.append(piece)
    return out


def first_difference(a: bytes, b: bytes, apart: FrozenSet[int] = frozenset(),
                     identity: FrozenSet[bytes] = frozenset()
                     ) -> Optional[Tuple[int, Optional[bytes], Optional[bytes]]]:
    """(index, A's piece, B's piece) of the first answer piece that differs beyond tolerance
    (a missing piece is None); None when the answers agree. The `list` blocks of the ports in
    ``apart`` are left out on both sides (:func:`parted_matrix`); so are, for two different
    builds, the lines that say which build each is (``identity``, fuzz/running/checked_run.py)."""
    if a == b:
        return None                       # (most steps: nothing to split)
    sync_a = _without_identity(_without_ports(synchronous_part(a)[0], apart), identity)
    sync_b = _without_identity(_without_ports(synchronous_part(b)[0], apart), identity)
    for i in range(max(len(sync_a), len(sync_b))):
        pa = sync_a[i] if i < len(sync_a) else None
        pb = sync_b[i] if i < len(sync_b) else None
        if pa is None or pb is None:
            return i, pa, pb
        if pa == pb:
            continue
        ea, eb = classify(pa.rstrip(b"\r\n")), classify(pb.rstrip(b"\r\n"))
        if pa.endswith(b"\r\n") == pb.endswith(b"\r\n") and _close(ea, eb):
            continue
        return i, pa, pb
    return None


def sync_bytes_before(answer: bytes, index: int, apart: FrozenSet[int] = frozenset()) -> int:
    """The bytes of ``answer``'s synchronous pieces before piece ``index`` (as
    :func:`first_difference` counts them, with the same ``apart``)."""
    return sum(len(p) for p in _without_ports(synchronous_part(answer)[0], apart)[:index])


def compare_answers(a: bytes, b: bytes, label_a: str = "A", label_b: str = "B") -> Optional[str]:
    """None when the answers agree within tolerance, else a description of the first difference."""
    diff = first_difference(a, b)
    if diff is None:
        return None
    i, pa, pb = diff
    return f"answer piece {i + 1}: {label_a} printed {pa!r}, {label_b} printed {pb!r}"
