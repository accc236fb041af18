"""Finding our own reply by content, not by counting line endings.

The ordinary fence (``version``, see :meth:`Session.fence`) knows which CRLF answers which host
line by counting: one CRLF per CR (FIRMWARE-BEHAVIOUR.md#fb-line). One lost or extra line ending on the link
and every later count is off. A *sync* puts a token in the stream that only its own reply can
contain, so it finds that reply whatever came before: garbage, a lost CRLF, a reboot.

How the token comes back (FIRMWARE-BEHAVIOUR.md#fb-line): with echo on every stored byte is echoed
as it arrives; a NUL ends what the parser reads, so bytes after it are stored and echoed but never
parsed. So
the sync sends ``echo 1⏎`` and then ``echo 0 ; version<NUL><token>⏎``: the HAT echoes the whole
second line (echo was on while it arrived), then CRLF, then runs ``echo 0`` and ``version``, and
prints no prompt (echo is off by then). Its reply is therefore the line ending in NUL + token,
followed at once by the ``Firmware version:`` line. A sync leaves echo off.
"""
from __future__ import annotations

import itertools
import os
from dataclasses import dataclass
from typing import Optional

__all__ = ["SyncResult", "sync_bytes", "new_token", "SYNC_ATTEMPTS", "SEPARATE_TAIL"]

SYNC_ATTEMPTS = 3
_counter = itertools.count(1)


def new_token() -> bytes:
    """A token no earlier reply can contain: this process and a counter."""
    return f"sync-{os.getpid():x}-{next(_counter)}".encode()


def sync_bytes(token: bytes, separate: bool = False) -> bytes:
    """The bytes of one sync: end any half-typed line, echo on, then the token's line.

    ``separate``: one command per line, for a HAT whose `;` separator is not (yet) trusted:
    ``version<NUL><token>⏎`` is echoed, answered, and followed by a prompt, then ``echo 0⏎``
    is echoed and turns echo off (its echo line is then the sync's last output)."""
    if separate:
        return b"\r" + b"echo 1\r" + b"version\x00" + token + b"\r" + SEPARATE_TAIL + b"\r"
    return b"\r" + b"echo 1\r" + b"echo 0 ; version\x00" + token + b"\r"


#: The last line of a separate-lines sync (its echo ends the sync's output).
SEPARATE_TAIL = b"echo 0"


@dataclass
class SyncResult:
    """Where a sync found itself: ``echo`` is the index of the event holding the token's echo,
    ``answer`` the index of the ``version`` line after it; ``attempts`` syncs were sent."""

    echo: int
    answer: int
    attempts: int
    token: bytes
    #: a start-up banner line arrived between the sync's start and its answer
    banner_at: Optional[int] = None
    #: the index of the sync's last event (the answer, or a separate sync's closing echo)
    last: int = -1

    @property
    def after(self) -> int:
        """The index just after the sync's own output."""
        return max(self.answer, self.last) + 1
