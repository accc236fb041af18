"""Talking to one target for the fuzzer: send input followed by a fence, read until it answers.

A fence is ``version`` + CR: its answer (``Firmware version: ...``) proves that everything sent
before it was processed. Over a slow link (pty, serial) several inputs, each with its own
fence, are written back to back so the link never waits idle; the answers are then cut apart at
the fence lines (:meth:`TargetExchange.exchange_batch`).

Every byte sent and received is kept in a :class:`Trace` (for the finding's script and transcript).
Times are HAT milliseconds: virtual time on the in-process target, scaled wall-clock otherwise.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

from ...harness.targets.base import Target, TargetError

__all__ = ["TargetExchange", "Trace", "FENCE", "ExchangeTimeout", "WIRE_BYTES_PER_S"]

FENCE = b"version\r"
WIRE_BYTES_PER_S = 11520     # 115200 baud, 8N1 (fb-uart)


class ExchangeTimeout(Exception):
    """The fence did not answer within the deadline; carries what did arrive."""

    def __init__(self, message: str, received: bytes):
        super().__init__(message)
        self.received = received


@dataclass
class Trace:
    """What crossed one link: ('send'|'recv', t_ms, bytes) and ('wait', t_ms, ms) entries."""

    label: str
    entries: List[Tuple[str, float, object]] = field(default_factory=list)

    def copy(self) -> Trace:
        return Trace(self.label, list(self.entries))


class TargetExchange:
    def __init__(self, target: Target, label: str, fence_s: float = 2.0):
        self.target = target
        self.trace = Trace(label)
        self.fence_s = fence_s
        self._virtual = hasattr(target, "advance") and "virtual_time" in getattr(target, "capabilities", ())
        self._t0 = time.monotonic()
        self._scale = target.time_scale or 1.0
        # H10 (baud-paced links): the incomplete last line of an answer, kept for the next
        # one. On a paced wire a line can be half-way across when the fence arrives.
        self._carry = b""
        self.sent_bytes = 0       # what crossed the wire each way (fences and syncs included)
        self.recv_bytes = 0

    @property
    def timed(self) -> bool:
        """Input takes time to arrive (a real-time or baud-paced target): the HAT may print
        between two bytes of one line."""
        # (the firmware in the loop declares ``wire_input``: its command port is a 115200-baud
        # wire in HAT time, so a line arrives byte by byte while the HAT prints)
        return (not self._virtual or bool(getattr(self.target, "baud", None))
                or "wire_input" in getattr(self.target, "capabilities", ()))

    @property
    def now(self) -> float:
        if self._virtual:
            return float(self.target.now)  # type: ignore[attr-defined]
        return (time.monotonic() - self._t0) * 1000.0 * self._scale

    @property
    def target_now(self) -> float:
        """HAT ms on a clock that the target keeps across links (:attr:`now` starts at this link's
        first use on a wall-clock target): for what outlives a run on a kept-open target."""
        if self._virtual:
            return float(self.target.now)  # type: ignore[attr-defined]
        return time.monotonic() * 1000.0 * self._scale

    def send(self, data: bytes) -> None:
        self.trace.entries.append(("send", self.now, bytes(data)))
        self.sent_bytes += len(data)
        self.target.write(data)

    def _got(self, data: bytes) -> None:
        if data:
            self.trace.entries.append(("recv", self.now, data))
            self.recv_bytes += len(data)

    def drain(self, quiet_s: float = 0.05, limit_s: float = 2.0) -> bytes:
        """Read until the target has been quiet for ``quiet_s`` (HAT seconds)."""
        out = bytearray()
        start = self.now
        while self.now - start < limit_s * 1000.0:
            data = self.target.read(quiet_s if self._virtual else quiet_s / self._scale)
            if not data:
                break
            self._got(data)
            out += data
        return bytes(out)

    def sync(self, fence_line: bytes, attempts: int = 3) -> None:
        """Wait until the target answers a fence (it may still be starting: a process, a HAT
        after reset). These bytes are link bookkeeping, recorded as ``sync`` (scripts skip them:
        a script runner syncs on its own when it opens the target)."""
        for attempt in range(attempts):
            self.trace.entries.append(("sync", self.now, FENCE))
            self.sent_bytes += len(FENCE)
            self.target.write(FENCE)
            start, buf = self.now, bytearray()
            while self.now - start < self.fence_s * 1000.0 * (attempt + 1):
                data = self.target.read(0.05 if self._virtual else 0.05 / self._scale)
                self._got(data)
                buf += data
                if fence_line in buf:
                    self.drain()
                    return
        raise ExchangeTimeout(f"no answer to `version` after {attempts} attempts", b"")

    def wait(self, ms: int) -> bytes:
        """Let ``ms`` HAT milliseconds pass; returns the output that arrived meanwhile."""
        self.trace.entries.append(("wait", self.now, ms))
        if self._virtual:
            self.target.advance(ms)  # type: ignore[attr-defined]
            return self._since_wait(self._read_now())
        out = bytearray()
        end = time.monotonic() + ms / 1000.0 / self._scale
        while True:
            left = end - time.monotonic()
            if left <= 0:
                break
            data = self.target.read(min(left, 0.05))
            self._got(data)
            out += data
        return self._since_wait(bytes(out))

    def settle(self, min_ms: int, max_ms: int) -> bytes:
        """:meth:`wait` for a TX ring to drain before a fence: ``max_ms`` HAT ms, or less on a
        target that tells when its command port is at rest (the firmware in the loop), but at
        least ``min_ms`` (the step's input still arriving). The trace keeps the ms that passed,
        so a replay waits as long."""
        settle = getattr(self.target, "settle", None) if self._virtual else None
        if settle is None or min_ms >= max_ms:
            return self.wait(max_ms)
        at = self.now
        waited = int(settle(min_ms, max_ms))
        self.trace.entries.append(("wait", at, waited))
        return self._since_wait(self._read_now())

    def _read_now(self) -> bytes:
        data = self.target.read(0)
        self._got(data)
        return data

    def _since_wait(self, data: bytes) -> bytes:
        """What a wait read, after what the last one carried over; a line still arriving when
        the wait ends belongs to what comes next (carried over again)."""
        out = self._carry + data
        keep = _incomplete_tail(out, 0)
        self._carry = out[len(out) - keep:] if keep else b""
        return out[:len(out) - keep] if keep else out

    def exchange(self, data: bytes, fence_line: bytes, fences: int, extra_bytes: int = 0) -> bytes:
        """Send ``data`` + fence; read until ``fences`` copies of ``fence_line`` arrived."""
        return self.exchange_batch([data], fence_line, [fences], [extra_bytes])[0]

    def exchange_batch(self, inputs: Sequence[bytes], fence_line: bytes, fences: Sequence[int],
                       extra_bytes: Sequence[int] = (), prompt: Optional[bool] = None) -> List[bytes]:
        """Pipelined: every input followed by a fence, all written at once; the answer is cut
        after each input's last fence line (and the prompt that may follow it)."""
        blob = b"".join(bytes(d) + FENCE for d in inputs)
        self.send(blob)
        answer = self.receive(fence_line, sum(fences), sum(extra_bytes), len(blob), prompt)
        return _cut(answer, fence_line, fences)

    def receive(self, fence_line: bytes, want: int, expected_out: int = 0, sent: int = 0,
                prompt: Optional[bool] = None, at_least: Optional[int] = None) -> bytes:
        """Read until ``want`` copies of ``fence_line`` arrived (and the prompt that may follow
        the last). The deadline is HAT time: the fence, plus the time the predicted output
        (``expected_out`` bytes) and the ``sent`` bytes need on the wire. ``at_least``: at the
        deadline, this many are enough (the others may have been lost to a full TX ring)."""
        deadline_ms = (self.fence_s + (expected_out + sent) / WIRE_BYTES_PER_S * 1.5) * 1000.0
        start = self.now
        buf = bytearray(self._carry)
        self._carry = b""
        slice_s = 0.05 if self._virtual else 0.05 / self._scale
        while buf.count(fence_line) < want:
            if self.now - start > deadline_ms:
                if at_least is not None and buf.count(fence_line) >= at_least:
                    break
                raise ExchangeTimeout(f"no answer to the fence within {deadline_ms:.0f} ms (HAT time): "
                                  f"{buf.count(fence_line)} of {want} fence line(s) arrived", bytes(buf))
            try:
                data = self.target.read(slice_s)
            except TargetError as exc:
                raise ExchangeTimeout(f"the target went away: {exc}", bytes(buf)) from None
            self._got(data)
            buf += data
        # A prompt may follow the last fence line; on a real link give it a moment to arrive.
        tail = bytes(buf[buf.rfind(fence_line) + len(fence_line):])
        # ``prompt=True`` (the caller knows echo is on): wait for it within the deadline (a
        # loaded machine can take longer than any fixed grace). H10: ``prompt=False`` skips the
        # wait (it idled the link for 20 ms after every batch). Paced virtual targets wait too.
        while prompt and self.timed and len(tail) < 3 and self.now - start <= deadline_ms:
            data = self.target.read(slice_s)
            self._got(data)
            buf += data
            tail = bytes(buf[buf.rfind(fence_line) + len(fence_line):])
        if not tail and prompt is None and self.timed:
            data = self.target.read(0.02 / self._scale)
            self._got(data)
            buf += data
        # H10: a prompt still crossing a paced wire (``P``, ``P0``) is completed first, and an
        # incomplete line after the answer is carried over to the next read, not judged half.
        end = buf.rfind(fence_line) + len(fence_line)
        while _PARTIAL_PROMPT.fullmatch(bytes(buf[end:])) and self.now - start <= deadline_ms:
            data = self.target.read(slice_s)
            self._got(data)
            buf += data
        keep = _incomplete_tail(bytes(buf), end)
        if keep:
            self._carry = bytes(buf[len(buf) - keep:])
            del buf[len(buf) - keep:]
        return bytes(buf)

_PARTIAL_PROMPT = re.compile(rb"P[0-3]?")
_PROMPT = re.compile(rb"P[0-3]>")


def _incomplete_tail(data: bytes, end: int) -> int:
    """Length of the unterminated bytes after the last CRLF (and after ``end``), unless they
    are a whole prompt: a line still arriving (H10, paced links)."""
    last = data.rfind(b"\r\n")
    start = max(end, last + 2 if last >= 0 else 0)     # (no CRLF at all: all of it is the line)
    tail = data[start:]
    if not tail or _PROMPT.fullmatch(tail):
        return 0
    if _PROMPT.match(tail):               # a prompt, then the start of the next line
        return len(tail) - 3
    return len(tail)


def _cut(data: bytes, fence_line: bytes, fences: Sequence[int]) -> List[bytes]:
    """Split ``data`` after the last fence line of each input (a prompt right after it stays)."""
    out: List[bytes] = []
    pos = 0
    for n in fences:
        end = pos
        for _ in range(n):
            i = data.find(fence_line, end)
            end = i + len(fence_line)
        if data.startswith(b"P", end) and data[end + 2:end + 3] == b">" and data[end + 1:end + 2].isdigit():
            end += 3
        out.append(data[pos:end])
        pos = end
    if out:
        out[-1] += data[pos:]
    return out

