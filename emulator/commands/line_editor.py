"""The command-port line editor shared by the firmware and the bootloader (FIRMWARE-BEHAVIOUR.md#fb-line,
#fb-bootloader).

- CR is the only terminator; it always produces CRLF (echo on or off) and hands the line over.
- BS (0x08) / DEL (0x7F) remove the last stored byte; with echo on they send ``08 20 08``.
  On an empty buffer they do nothing at all.
- Every other byte (LF, TAB, NUL, >= 0x80 ...) is stored and echoed; when the buffer is full
  (256 bytes) further bytes up to the CR are dropped silently.

What happens to a finished line (``#`` comments, dispatch, the prompt) is the caller's job.
The bootloader uses the same editor with echo always on.
"""
from __future__ import annotations

from typing import Callable, Optional, Tuple

__all__ = ["LineEditor", "LINE_BUFFER", "CR", "CRLF"]

LINE_BUFFER = 256
CR = 0x0D
CRLF = b"\r\n"
_RUBOUT = (0x08, 0x7F)
_RUBOUT_ECHO = b"\x08 \x08"


class LineEditor:
    """Collects bytes into a line. ``echo`` is read at every byte (it can change mid-line)."""

    def __init__(self, write_out: Callable[[bytes], None], echo: Callable[[], bool],
                 size: int = LINE_BUFFER):
        self._write = write_out
        self._echo = echo
        self.size = size
        self.buffer = bytearray()

    def feed(self, byte: int) -> Optional[bytes]:
        """Take one received byte; returns the finished line when it was a CR."""
        if byte == CR:
            return self._end_line()
        if byte in _RUBOUT:
            if self.buffer:
                self.buffer.pop()
                if self._echo():
                    self._write(_RUBOUT_ECHO)
            return None
        if len(self.buffer) < self.size:
            self.buffer.append(byte)
            if self._echo():
                self._write(bytes((byte,)))
        return None

    def feed_run(self, data: bytes, start: int) -> Tuple[int, Optional[bytes]]:
        """Take ``data[start:]`` up to and including the first CR, as :meth:`feed` would byte
        by byte; returns (index after what was taken, the finished line or None).

        The fast path of the main loop (H10 profile: per-byte calls were most of the time a
        fuzzed line cost). Echo is read once per run: it only changes when a line is
        processed, which happens after the CR that ends the run."""
        end = data.find(b"\r", start)
        stop = len(data) if end < 0 else end
        chunk = data[start:stop]
        if chunk:
            if b"\x08" in chunk or b"\x7f" in chunk:
                for byte in chunk:            # rubouts: the exact per-byte rules
                    self.feed(byte)
            else:
                stored = chunk[:max(0, self.size - len(self.buffer))]
                if stored:
                    self.buffer += stored
                    if self._echo():
                        self._write(stored)
        if end < 0:
            return stop, None
        return end + 1, self._end_line()

    def _end_line(self) -> bytes:
        """The CR: CRLF goes out (echo on or off) and the stored line is handed over."""
        self._write(CRLF)
        line = bytes(self.buffer)
        self.buffer.clear()
        return line

    def clear(self) -> None:
        self.buffer.clear()
