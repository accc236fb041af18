"""Upload progress: a bar redrawn in place on a terminal, plain lines now and then otherwise
(a CI log must not fill with carriage returns)."""
from __future__ import annotations

import sys
import time
from typing import Callable, Optional, TextIO

__all__ = ["Progress"]

_WIDTH = 30
_LINE_EVERY = 2.0          # seconds between plain lines when not on a terminal


class Progress:
    def __init__(self, total: int, label: str = "upload", stream: Optional[TextIO] = None,
                 tty: Optional[bool] = None, clock: Callable[[], float] = time.monotonic):
        self.total = max(1, int(total))
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.tty = self.stream.isatty() if tty is None else tty
        self.clock = clock
        self.start = clock()
        self._last_line = self.start
        self._last_drawn = -1
        self._done = False

    def _text(self, done: int) -> str:
        pct = 100 * done // self.total
        elapsed = self.clock() - self.start
        return f"{self.label}: {pct:3d}% {done}/{self.total} bytes {elapsed:.1f} s"

    def update(self, done: int) -> None:
        if self._done:
            return
        if self.tty:
            filled = _WIDTH * done // self.total
            if filled == self._last_drawn and done < self.total:
                return
            self._last_drawn = filled
            bar = "#" * filled + "-" * (_WIDTH - filled)
            self.stream.write(f"\r[{bar}] {self._text(done)}")
            self.stream.flush()
        elif self.clock() - self._last_line >= _LINE_EVERY:
            self._last_line = self.clock()
            self.stream.write(self._text(done) + "\n")
            self.stream.flush()

    def finish(self, done: int) -> None:
        """The last state, on its own line (also when the upload stopped early)."""
        if self._done:
            return
        if self.tty:
            self.update(done)
            self.stream.write("\n")
        else:
            self.stream.write(self._text(done) + "\n")
        self.stream.flush()
        self._done = True
