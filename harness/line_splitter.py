"""From received bytes to events: complete CRLF lines, prompts (which have no CRLF), and the
echo of the host's own lines (FIRMWARE-BEHAVIOUR.md#fb-line). Each complete line is then classified by
:func:`~.events.classify`.
"""
from __future__ import annotations

import re
from typing import List, Optional, Tuple

from .events import UNASKED_KINDS, Event, classify, decode

__all__ = ["LineSplitter", "expected_echo", "BOOTLOADER_PROMPT", "MAX_LINE"]

_FW_PROMPT = re.compile(rb"P(\d)>")
BOOTLOADER_PROMPT = b"BHBL> "


def expected_echo(sent: bytes) -> bytes:
    """What the line editor echoes for the bytes of one host line, CR excluded
    (FIRMWARE-BEHAVIOUR.md#fb-line): each stored byte as is; BS/DEL remove the last byte and
    echo BS SP BS (nothing when the buffer is empty); bytes past the 256-byte buffer are
    dropped silently."""
    buf, out = bytearray(), bytearray()
    for b in sent:
        if b in (0x08, 0x7F):
            if buf:
                buf.pop()
                out += b"\x08 \x08"
        elif len(buf) < 256:
            buf.append(b)
            out.append(b)
    return bytes(out)


MAX_LINE = 1024     # bytes without CRLF after which output is cut into an ``unknown`` event


class LineSplitter:
    """Turns received bytes into events: complete CRLF lines and prompts.

    A prompt is recognised at the start of a line as soon as its bytes are there (it is
    never followed by CRLF). For every CR the host sends, the firmware answers with
    CRLF, preceded by the echo of the line when echo is on: the first line to arrive
    that is blank, or equal to that echo, is classified ``blank`` / ``echo`` and carries
    ``fields["host_line"]``, the number :meth:`host_sent` returned for that line.

    With echo on, a line the HAT prints on its own (a PID line every 10 ms, a data report:
    ``UNASKED_KINDS``) may come between two bytes of an echo, as the host's bytes are echoed
    while they arrive: ``ech`` + ``P0: pv=...`` CRLF + ``o 0`` CRLF. That line is its own event
    and the echo is put back together around it; otherwise the echo would never be recognised
    and every later line ending counted against the wrong host line.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self._host_line = bytearray()      # host bytes since its last CR
        self._pending: List[Tuple[int, bytes]] = []  # (host line number, expected echo)
        self._next_line = 0
        self._echo_head = b""              # the start of the oldest pending echo, torn by a line

    @property
    def partial(self) -> bytes:
        """Received bytes not yet ended by CRLF (and not a prompt)."""
        return bytes(self._buf)

    def host_sent(self, data: bytes) -> List[int]:
        """Note bytes the host sent; returns the numbers of the host lines ended by CR in them."""
        ended = []
        for b in data:
            if b == 0x0D:
                self._next_line += 1
                self._pending.append((self._next_line, expected_echo(bytes(self._host_line))))
                self._host_line.clear()
                ended.append(self._next_line)
            else:
                self._host_line.append(b)
        # A target that never answers must not make this grow without bound.
        del self._pending[:-64]
        return ended

    def pending_lines(self) -> List[int]:
        """Numbers of the host lines whose CRLF has not been seen yet, oldest first."""
        return [n for n, _echo in self._pending]

    def forget_pending(self) -> None:
        """Stop waiting for the CRLF of earlier host lines (after losing step with the target)."""
        self._pending.clear()
        self._echo_head = b""

    def feed(self, data: bytes, t: float) -> List[Event]:
        self._buf += data
        out: List[Event] = []
        while True:
            prompt = self._take_prompt(t)
            if prompt is not None:
                out.append(prompt)
                continue
            i = self._buf.find(b"\r\n")
            if i < 0:
                if len(self._buf) > MAX_LINE:
                    # No HAT line is this long (its longest, help text, is < 120 bytes): garbage.
                    # Cut it into bounded events so it cannot grow the buffer (or the cost of
                    # searching it) without bound.
                    chunk = bytes(self._buf[:MAX_LINE])
                    del self._buf[:MAX_LINE]
                    out.append(Event("unknown", decode(chunk), chunk, t, {"overlong": True}))
                    continue
                break
            line = bytes(self._buf[:i])
            del self._buf[:i + 2]
            out += self._line_events(line, t)
        return out

    def _take_prompt(self, t: float) -> Optional[Event]:
        if self._buf.startswith(BOOTLOADER_PROMPT):
            del self._buf[:len(BOOTLOADER_PROMPT)]
            return Event("bootloader_prompt", BOOTLOADER_PROMPT.decode(), BOOTLOADER_PROMPT, t, {})
        m = _FW_PROMPT.match(self._buf)
        if m:
            # read the groups before deleting: a match on a bytearray sees later changes
            raw, port = bytes(m.group(0)), int(m.group(1))
            del self._buf[:len(raw)]
            return Event("prompt", raw.decode(), raw, t, {"port": port})
        return None

    def _line_events(self, line: bytes, t: float) -> List[Event]:
        if not self._pending:
            return [classify(line, t)]
        number, echo = self._pending[0]
        whole = self._echo_head + line
        if whole == echo:
            self._pending.pop(0)
            self._echo_head = b""
            kind = "blank" if not whole else "echo"
            return [Event(kind, decode(whole), whole, t, {"host_line": number, "echo": bool(whole)})]
        if not line:
            # Echo off (or an edited line whose echo we cannot predict): the CRLF alone.
            self._pending.pop(0)
            self._echo_head = b""
            return [Event("blank", "", line, t, {"host_line": number, "echo": False})]
        torn = self._torn(line, echo, t)
        if torn is not None:
            return [torn]
        return [classify(line, t)]

    def _torn(self, line: bytes, echo: bytes, t: float) -> Optional[Event]:
        """``line`` as more of the pending echo followed by a whole line the HAT printed on its
        own: that line's event (the echo's part is kept for the next line), else None."""
        head = self._echo_head
        for k in range(1, len(line)):
            if not echo.startswith(head + line[:k]):
                return None
            rest = classify(line[k:], t)
            if rest.kind in UNASKED_KINDS:
                self._echo_head = head + line[:k]
                return rest
        return None
