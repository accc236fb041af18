"""An open Session's byte stream as a :class:`Target`, so ``load`` can run inside a session.

``run`` reloads the release after it reset a dead HAT (conformance/plugin/recovery.py) without closing
the session: the session's reader keeps reading (every byte still reaches the run's transcript)
and ``load``'s :class:`~.wire.Wire` reads what the session received, from where it began.
"""
from __future__ import annotations

from typing import Any

from ..targets.base import Target

__all__ = ["SessionStream"]


class SessionStream(Target):
    """Bytes to and from ``session``'s target, read from the session's own record of them."""

    def __init__(self, session: Any):
        self.session = session
        inner = session.target
        self.url = inner.url
        self.capabilities = inner.capabilities
        self.control = inner.control
        self.wire_baud = getattr(inner, "wire_baud", None) or getattr(inner, "baudrate", None)
        self._pos = len(session.received)
        self.is_open = True

    def open(self) -> None:
        """The session's target is open already."""

    def close(self) -> None:
        """The session closes its target."""

    def write(self, data: bytes) -> None:
        self.session.send_raw(data)

    def read(self, timeout: float) -> bytes:
        data = self.session.bytes_since(self._pos, timeout)
        # (a long-running session forgets its oldest bytes: the position never points before them)
        self._pos = max(self._pos, self.session.received.dropped) + len(data)
        return data
