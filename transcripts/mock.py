"""``buildhat-conformance mock FILE [--pty|--tcp PORT]``: serve a transcript as a fake HAT.

The recording is cut into exchanges: the start-up output (everything the HAT said before the
host first spoke), then one exchange per host line (the bytes up to and including a CR) with
the output that followed it, each output chunk at its recorded delay after the host line.
When the host sends the next recorded line, the mock answers with what the HAT answered.

The fake HAT is served on a pty or TCP by transcripts/mock_serve.py.

A host line that departs from the recording is reported and answered with nothing (a fake
that answered anyway would make a host look right when it is not). If the same line appears
a little further on in the recording (the host skipped something), the mock moves on to it
and reports the skipped lines. ``--strict`` stops at the first departure with exit status 1.
"""
from __future__ import annotations

import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Callable, Deque, List, Optional, Tuple

from ..harness.transcript import CRLF, Transcript, field_bytes

__all__ = ["Exchange", "MockHat", "exchanges_of"]


@dataclass
class Exchange:
    """One recorded host line (None for the start-up) and the output that followed it."""

    host: Optional[bytes]
    t: float
    output: List[Tuple[float, bytes]] = field(default_factory=list)   # (ms after the host line, bytes)


def _output_bytes(ev: dict) -> bytes:
    if "line" in ev:
        return field_bytes(ev, "line") + CRLF
    if "partial" in ev:
        return field_bytes(ev, "partial")
    return b""


def _starts_reply(line: bytes, host: bytes) -> bool:
    """Whether an output line is the CRLF that ``host``'s CR produced (FIRMWARE-BEHAVIOUR.md#fb-line: the CR
    always gives CRLF, so every reply starts with it): an empty line with echo off, the echoed
    text (after any prompt still on the line) with echo on."""
    sent = host.rstrip(b"\r")
    return line == b"" or (bool(sent) and line.endswith(sent))


def exchanges_of(transcript: Transcript) -> List[Exchange]:
    """The start-up exchange, then one per CR-terminated host line.

    Output is attributed by the protocol's own reply shape, not by when it came: each host
    line's reply begins with the CRLF of its CR, so when several lines were sent before any
    answer (a script without ``@wait``), the first output line of that shape starts the reply
    to the first of them, the next one to the second, and so on. Everything else (the rest of
    a reply, asynchronous lines) belongs to the reply begun last.

    Host lines before t = 0 are the recorder's own look at the target before the script (a
    session's ``version``, the ``list`` that waits for the layout; TRANSCRIPT.md: t < 0 is
    start-up): they and their answers are not served."""
    startup = Exchange(None, 0.0)
    ex: List[Exchange] = [startup]
    current = startup
    waiting: Deque[Exchange] = deque()      # sent, the CR's CRLF not seen yet
    first_t: Optional[float] = None
    pending = bytearray()
    for ev in transcript.events:
        kind = ev.get("dir")
        t = float(ev.get("t", 0))
        if kind == "hat":
            data = _output_bytes(ev)
            if first_t is None:
                first_t = t
            if "line" in ev and waiting and _starts_reply(field_bytes(ev, "line"), waiting[0].host or b""):
                current = waiting.popleft()
            dt = t - (current.t if current.host is not None else first_t)
            if "partial" in ev:
                # A partial is stamped when it was flushed (the next host send or the end), not
                # when it arrived; a prompt comes with the output before it, so send it then.
                dt = current.output[-1][0] if current.output else 0.0
            current.output.append((max(0.0, dt), data))
        elif kind == "host" and t < 0:
            current = Exchange(b"", t)      # the recorder's own exchange: kept out of the mock
        elif kind == "host":
            pending += field_bytes(ev, "bytes")
            while b"\r" in pending:
                i = pending.index(b"\r")
                exchange = Exchange(bytes(pending[:i + 1]), t)
                ex.append(exchange)
                waiting.append(exchange)
                del pending[:i + 1]
    return ex


class MockHat:
    """The fake HAT, independent of the transport: ``feed`` host bytes, output goes to ``write``."""

    def __init__(self, transcript: Transcript, write: Callable[[bytes], None], speed: Optional[float] = None,
                 lookahead: int = 64, log: Optional[Callable[[str], None]] = None):
        if speed is None:
            # Recorded times are HAT ms; a recording from a sped-up emulator played at its own
            # scale gives the host the same wall-clock pace it saw.
            speed = float(transcript.meta.get("time_scale") or 1.0)
        if speed <= 0:
            raise ValueError("speed must be positive")
        self.exchanges = exchanges_of(transcript)
        self._write = write
        self.speed = speed
        self.lookahead = lookahead
        self.log = log or (lambda msg: print(f"mock: {msg}", file=sys.stderr, flush=True))
        self.next = 1                  # index of the next expected exchange
        self.matched = 0
        self.departures: List[bytes] = []
        self.skipped: List[bytes] = []
        self._line = bytearray()
        self._queue: Deque[Tuple[float, bytes]] = deque()
        self._cv = threading.Condition()
        self._closed = False
        self._thread = threading.Thread(target=self._pump, name="mock-output", daemon=True)

    # -- output --------------------------------------------------------------------------
    def start(self) -> None:
        """Begin serving: the start-up output first, all at once. The recorded host came after the
        start-up (t < 0 is before its first byte); a host opening the device now should find the
        HAT as the recording's host did: booted, with the boot text in the past (pyserial
        flushes the input buffer when it opens a port)."""
        self._thread.start()
        startup = self.exchanges[0]
        self._schedule(Exchange(None, 0.0, [(0.0, data) for _dt, data in startup.output]),
                       release_earlier=False)

    def _schedule(self, ex: Exchange, release_earlier: bool = True) -> None:
        now = time.monotonic()
        with self._cv:
            if release_earlier:
                # The recording had all earlier output out before this host line: keep that order.
                self._queue = deque((min(due, now), data) for due, data in self._queue)
            for dt, data in ex.output:
                self._queue.append((now + max(0.0, dt) / 1000.0 / self.speed, data))
            self._cv.notify_all()

    def _pump(self) -> None:
        while True:
            with self._cv:
                while not self._closed and not self._queue:
                    self._cv.wait()
                if self._closed:
                    return
                due, data = self._queue[0]
                delay = due - time.monotonic()
                if delay > 0:
                    self._cv.wait(delay)
                    continue
                self._queue.popleft()
            try:
                self._write(data)
            except OSError as exc:
                self.log(f"cannot write to the host any more ({exc}); output stopped")
                return

    def idle(self) -> bool:
        """True when every scheduled byte has been written."""
        with self._cv:
            return not self._queue

    # -- input ---------------------------------------------------------------------------
    def feed(self, data: bytes) -> List[bytes]:
        """Host bytes; returns the host lines in them that departed from the recording."""
        departed = []
        for b in data:
            self._line.append(b)
            if b == 0x0D:
                line = bytes(self._line)
                self._line.clear()
                if not self._answer(line):
                    departed.append(line)
        return departed

    def _answer(self, line: bytes) -> bool:
        window = self.exchanges[self.next:self.next + self.lookahead]
        for k, ex in enumerate(window):
            if ex.host == line:
                for skipped in window[:k]:
                    self.skipped.append(skipped.host or b"")
                    self.log(f"the host did not send recorded line {skipped.host!r} (moved on)")
                self.next += k + 1
                self.matched += 1
                self._schedule(ex)
                return True
        expected = self.exchanges[self.next].host if self.next < len(self.exchanges) else None
        self.departures.append(line)
        self.log(f"host line departs from the recording: got {line!r}, expected "
                 f"{expected!r}" if expected is not None else
                 f"host line after the end of the recording: {line!r}")
        return False

    @property
    def finished(self) -> bool:
        return self.next >= len(self.exchanges)

    def summary(self) -> str:
        left = len(self.exchanges) - self.next
        return (f"{self.matched} host line(s) answered, {len(self.departures)} departed, "
                f"{len(self.skipped)} recorded line(s) skipped, {left} not reached")

    def close(self) -> None:
        with self._cv:
            self._closed = True
            self._cv.notify_all()
        if self._thread.is_alive():
            self._thread.join(timeout=2)
