"""What one host line produced (:class:`Reply`), and the lines a HAT prints on its own that a
reply must be able to leave out (docs/FIRMWARE-BEHAVIOUR.md#fb-async, #fb-data, #fb-debug)."""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, List

__all__ = ["Reply", "ASYNC_LINE", "ASYNC_BYTES", "without_fence_line"]

# Lines the HAT may print at any time (docs/FIRMWARE-BEHAVIOUR.md#fb-async, #fb-data, #fb-debug): a
# reply that contains one of these was interleaved with something asynchronous and an exact
# comparison must retry.
ASYNC_LINE = re.compile(
    r"P[0-3]: (?:connecting|connected to|established|disconnected|timeout|checksum|too many|button|"
    r"pulse done|ramp done|pv=|DATA)|P[0-3][MCV][0-9]*:|set baud rate|deltat=|Port power fault|"
    r"Motor power fault| Port 4D|   [0-3]  |type [0-9A-F]{2}$|  nmodes|MQ overrun")


# Whole lines a HAT prints on its own between (never inside) command outputs: the R1 passive
# re-connect every scan, data reports, PID debug, completion messages
# (docs/FIRMWARE-BEHAVIOUR.md#fb-r1-passive, #fb-data-lines, #fb-debug-pid, #fb-waveform-end).
# ``Reply.raw`` leaves them out so a reply can be compared byte for byte; ``Reply.wire`` keeps all.
ASYNC_BYTES = re.compile(
    rb"P[0-3]: (?:connected to passive ID [0-9]+|disconnected|button (?:pressed|released)|pulse done|"
    rb"ramp done|timeout during data phase: disconnecting)\r\n|P[0-3][MCV][0-9]*:[^\r\n]*\r\n|"
    rb"P[0-3]: (?:pv=|DATA )[^\r\n]*\r\n|deltat=[0-9A-F]{8}\r\n")


def without_fence_line(head: bytes) -> bytes:
    """``head`` (what came before the fence's ``Firmware version:`` answer) without the bytes of
    the fence line itself at its end: the CRLF its CR gave and, with echo on, the echoed
    ``version`` before that. A stream left on (PID lines every 10 ms) may print a whole line of
    its own between any two of those bytes (after the echo, before the CRLF); such lines are
    kept where they are, so that :attr:`Reply.raw` leaves them out and :attr:`Reply.wire` keeps
    them, and the fence's bytes are found around them."""
    own = bytearray(len(head))          # 1: a byte of an asynchronous line, never the fence's
    for m in ASYNC_BYTES.finditer(head):
        own[m.start():m.end()] = b"\x01" * (m.end() - m.start())
    plain = [i for i in range(len(head)) if not own[i]]
    cut: List[int] = []
    for suffix in (b"\r\n", b"version"):
        n = len(suffix)
        rest = plain[:len(plain) - len(cut)]
        if len(rest) >= n and bytes(head[i] for i in rest[-n:]) == suffix:
            cut += rest[-n:]
    if not cut:
        return head
    gone = set(cut)
    return bytes(b for i, b in enumerate(head) if i not in gone)


_LIST_HEADER = re.compile(r"P([0-3]): (?:no device detected|connected to )")


@dataclass
class Reply:
    """What one host line produced. ``wire``: every byte before the fence, CRLFs included;
    ``raw``: the same without the asynchronous lines of ``ASYNC_BYTES``."""

    sent: bytes
    wire: bytes
    events: List[Any] = field(default_factory=list)

    @property
    def raw(self) -> bytes:
        return ASYNC_BYTES.sub(b"", self.wire)

    @property
    def lines(self) -> List[str]:
        """Complete lines (CRLF-terminated) as text; a trailing prompt is not a line."""
        parts = self.raw.split(b"\r\n")
        return [p.decode("utf-8", errors="replace") for p in parts[:-1]]

    def list_lines(self) -> List[str]:
        """The lines of a ``list`` dump: asynchronous lines dropped, including a port header
        out of sequence (R1 repeats ``P<n>: connected to passive ID`` on its own,
        docs/FIRMWARE-BEHAVIOUR.md#fb-r1-passive)."""
        out, expected = [], 0
        for line in self.wire.split(b"\r\n")[:-1]:
            text = line.decode("utf-8", errors="replace")
            if not text or ASYNC_BYTES.fullmatch(line + b"\r\n") and not _LIST_HEADER.match(text):
                continue
            m = _LIST_HEADER.match(text)
            if m:
                if int(m.group(1)) != expected:
                    continue
                expected += 1
            out.append(text)
        return out

    @property
    def text_lines(self) -> List[str]:
        """Lines without the blank ones (the CRLF every CR produces)."""
        return [line for line in self.lines if line]

    @property
    def errors(self) -> int:
        return self.lines.count("Error")

    def after_processing(self) -> List[Any]:
        """The events after the CRLF (or echo) the sent line produced: what the HAT printed
        once it had processed the line. Lines before it were already on their way (printed
        earlier in HAT time), however late they reached the host."""
        for i, e in enumerate(self.events):
            if "host_line" in getattr(e, "fields", {}):
                return self.events[i + 1:]
        return list(self.events)

    def kinds(self, kind: str) -> List[Any]:
        return [e for e in self.events if getattr(e, "kind", None) == kind]
