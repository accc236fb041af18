"""JSONL transcripts (shared/formats/TRANSCRIPT.md): writer, reader, byte-stream rebuild.

The writer flushes every event as it is written, so a crash loses nothing that was
received. Output bytes from the HAT are split into ``line`` events at CRLF; bytes not
yet ended by CRLF become a ``partial`` event when the host next sends, the run ends, or they
have waited :data:`PARTIAL_MAX_AGE` seconds for their CRLF (whoever reads the target calls
:meth:`TranscriptWriter.flush_stale` after every read, so a kill -9 loses none of them), or
there are :data:`PARTIAL_MAX_BYTES` of them (a garbage flood is written as it comes, not held).
"""
from __future__ import annotations

import io
import json
import os
import time
from dataclasses import dataclass, field
from typing import IO, Iterable, Iterator, List, Optional, Union

__all__ = ["TranscriptWriter", "Transcript", "read_transcript", "iter_events", "hat_stream",
           "host_stream", "text_field", "field_bytes"]

CRLF = b"\r\n"
# A line split by a pause this long is rare on a healthy link (a 100-byte line takes 9 ms at
# 115200 baud); output that waits longer (a prompt, a half line from a dying HAT) goes to disk.
PARTIAL_MAX_AGE = 0.1
PARTIAL_MAX_BYTES = 4096


def text_field(data: bytes) -> tuple[str, Optional[str]]:
    """(text, hex) for a byte string: valid UTF-8 decodes as is; otherwise every byte that
    is not part of a valid UTF-8 sequence becomes U+00XX and the raw bytes go in ``hex``."""
    try:
        return data.decode("utf-8"), None
    except UnicodeDecodeError:
        text = data.decode("utf-8", errors="surrogateescape")
        text = "".join(chr(ord(c) - 0xDC00) if 0xDC80 <= ord(c) <= 0xDCFF else c for c in text)
        return text, data.hex(" ").upper()


def field_bytes(event: dict, key: str) -> bytes:
    """The exact bytes of a text field (``line``, ``partial``, ``bytes``) of an event."""
    if "hex" in event:
        return bytes.fromhex(event["hex"])
    return event[key].encode("utf-8")


class TranscriptWriter:
    """Writes one transcript. ``t`` values are milliseconds relative to the script start.

    Use :meth:`host` for bytes sent, :meth:`hat` for bytes received (any chunking),
    :meth:`event` for device-side and drive events, and :meth:`end` to finish.
    """

    def __init__(self, dest: Union[str, os.PathLike, IO[str]], meta: dict):
        if isinstance(dest, (str, os.PathLike)):
            os.makedirs(os.path.dirname(os.fspath(dest)) or ".", exist_ok=True)
            self._fh: IO[str] = open(dest, "w", encoding="utf-8")
            self._owned = True
            self.path: Optional[str] = os.fspath(dest)
        else:
            self._fh, self._owned, self.path = dest, False, None
        if "firmware" not in meta:
            meta = dict(meta, firmware="unknown")
        self._pending = bytearray()
        self._pending_t: Optional[float] = None
        self._pending_since = 0.0          # monotonic time the oldest pending byte arrived
        self._ended = False
        self._write(dict({"dir": "meta"}, **meta))

    # -- low level ---------------------------------------------------------------------
    def _write(self, obj: dict, flush: bool = True) -> None:
        if self._fh.closed:
            return
        self._fh.write(json.dumps(obj, ensure_ascii=True, separators=(",", ":")) + "\n")
        if flush:
            self._fh.flush()

    @staticmethod
    def _t(t: float) -> Union[int, float]:
        r = round(float(t), 3)
        return int(r) if r == int(r) else r

    def _text_event(self, t: float, key: str, data: bytes, kind: str = "hat", flush: bool = True) -> None:
        text, hx = text_field(data)
        obj = {"t": self._t(t), "dir": kind, key: text}
        if hx is not None:
            obj["hex"] = hx
        self._write(obj, flush)

    # -- public ------------------------------------------------------------------------
    def host(self, t: float, data: bytes) -> None:
        """Bytes the host sent. Pending HAT output becomes a ``partial`` first."""
        self.flush_partial()
        self._text_event(t, "bytes", bytes(data), kind="host")

    def hat(self, t: float, data: bytes) -> None:
        """Bytes received from the HAT, in any chunking; complete lines are written at once."""
        if not data:
            return
        if not self._pending:
            self._pending_since = time.monotonic()
        self._pending += data
        lines = 0
        while True:
            i = self._pending.find(CRLF)
            if i < 0:
                break
            line = bytes(self._pending[:i])
            del self._pending[: i + 2]
            # One flush for the chunk, not one per line (a flood is thousands of lines a second).
            self._text_event(t, "line", line, flush=False)
            lines += 1
        if lines and not self._fh.closed:
            self._fh.flush()
        # A partial is stamped with the time its last byte arrived, not when it is flushed.
        self._pending_t = t
        if self._pending:
            if len(self._pending) >= PARTIAL_MAX_BYTES:
                self.flush_partial()
        else:
            self._pending_t = None

    def flush_stale(self, max_age: float = PARTIAL_MAX_AGE) -> None:
        """Write pending output that has waited ``max_age`` seconds for its CRLF."""
        if self._pending and time.monotonic() - self._pending_since >= max_age:
            self.flush_partial()

    def flush_partial(self, t: Optional[float] = None) -> None:
        """Write pending output as a ``partial`` event, stamped with its own arrival time
        (``t`` only when nothing better is known)."""
        if self._pending:
            data = bytes(self._pending)
            self._pending.clear()
            self._text_event(self._pending_t if self._pending_t is not None else (t or 0.0), "partial", data)
            self._pending_t = None

    def event(self, kind: str, t: float, **fields) -> None:
        """Any other event kind (dev, devrx, pwm, led, note) with its fields."""
        obj = {"t": self._t(t), "dir": kind}
        obj.update(fields)
        self._write(obj)

    def note(self, t: float, text: str) -> None:
        self.event("note", t, text=text)

    def end(self, t: float) -> None:
        if self._ended:
            return
        self.flush_partial(t)
        self._write({"t": self._t(t), "dir": "end"})
        self._ended = True

    def close(self, t: Optional[float] = None) -> None:
        """Flush a pending partial (a crash-time close still keeps every byte) and close."""
        if t is not None:
            self.end(t)
        else:
            self.flush_partial()
        if self._owned and not self._fh.closed:
            self._fh.close()

    def __enter__(self) -> TranscriptWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@dataclass
class Transcript:
    meta: dict
    events: List[dict] = field(default_factory=list)

    def of(self, *kinds: str) -> List[dict]:
        return [e for e in self.events if e.get("dir") in kinds]

    @property
    def hat_bytes(self) -> bytes:
        return hat_stream(self.events)

    @property
    def host_bytes(self) -> bytes:
        return host_stream(self.events)

    def hat_lines(self) -> List[str]:
        return [e["line"] for e in self.events if e.get("dir") == "hat" and "line" in e]


def iter_events(source: Union[str, os.PathLike, IO[str], Iterable[str]]) -> Iterator[dict]:
    """Events of a transcript, meta first. A truncated last line (crash) is skipped."""
    if isinstance(source, (str, os.PathLike)):
        with open(source, encoding="utf-8") as fh:
            yield from iter_events(list(fh))
        return
    lines = source.readlines() if isinstance(source, io.IOBase) else list(source)
    for n, raw in enumerate(lines, 1):
        raw = raw.strip()
        if not raw:
            continue
        try:
            yield json.loads(raw)
        except json.JSONDecodeError:
            if n == len(lines):  # the writer died mid-line; everything before it is intact
                return
            raise ValueError(f"transcript line {n} is not JSON: {raw[:80]!r}") from None


def read_transcript(source) -> Transcript:
    events = list(iter_events(source))
    if not events or events[0].get("dir") != "meta":
        raise ValueError("not a transcript: the first line must be a {\"dir\":\"meta\"} object")
    return Transcript(meta=events[0], events=events[1:])


def hat_stream(events: Iterable[dict]) -> bytes:
    """The exact byte stream the HAT sent: every partial, and every line + CRLF, in order."""
    out = bytearray()
    for e in events:
        if e.get("dir") != "hat":
            continue
        if "line" in e:
            out += field_bytes(e, "line") + CRLF
        elif "partial" in e:
            out += field_bytes(e, "partial")
    return bytes(out)


def host_stream(events: Iterable[dict]) -> bytes:
    return b"".join(field_bytes(e, "bytes") for e in events if e.get("dir") == "host")
