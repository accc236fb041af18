"""Ctrl-C (SIGINT) and SIGTERM while a campaign runs: the first stops it, the second kills it.

The first signal raises KeyboardInterrupt wherever the main thread is (fuzzing, replaying a finding,
reducing it): the campaign keeps what it found, closes its targets and writes its files, and the
command exits 130. From then on, and once the files are being written (:meth:`StopSignals.hold`),
a signal no longer interrupts; a second one ends the process at once (exit 130), after the actions
registered with :meth:`StopSignals.at_kill` (the ``--jobs`` workers killed). What this process
started goes with it: the emulator and ``cmd:`` processes get a signal when their parent dies
(plumbing/parent_death.py), and a firmware in the loop exits when its pipe closes.
"""
from __future__ import annotations

import os
import signal
import threading
from contextlib import contextmanager
from types import FrameType
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence

__all__ = ["StopSignals", "EXIT_INTERRUPTED"]

EXIT_INTERRUPTED = 130


class StopSignals:
    """Installs the handlers for ``signals`` while in its ``with`` block (main thread only;
    elsewhere it does nothing). ``say``: a line written (raw, to stderr) at the first signal;
    ``kill``: how the second ends the process."""

    def __init__(self, signals: Sequence[int] = (signal.SIGINT, signal.SIGTERM), say: str = "",
                 kill: Optional[Callable[[], None]] = None):
        self.signals = tuple(signals)
        self.say = say
        self.received = 0
        self._mode = "raise"          # raise | defer (till the block ends) | hold (count only)
        self._pending = False
        self._kill_actions: List[Callable[[], None]] = []
        self._kill = kill or (lambda: os._exit(EXIT_INTERRUPTED))
        self._previous: Dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for sig in self.signals:
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *_exc: object) -> None:
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)
        self._previous.clear()

    def at_kill(self, action: Callable[[], None]) -> None:
        """Run ``action`` before the process ends at a second signal."""
        self._kill_actions.append(action)

    @property
    def stopped(self) -> bool:
        return self.received > 0

    def hold(self) -> None:
        """From now on a first signal is counted, not raised (the campaign is over: its files are
        being written, and are finished); a second still kills."""
        self._mode = "hold"

    @contextmanager
    def deferring(self) -> Iterator[None]:
        """A first signal in this block is raised at its end, not inside it (a message half sent
        on a pipe would garble the ones after it)."""
        if self._mode != "raise":
            yield
            return
        self._mode = "defer"
        try:
            yield
        finally:
            if self._mode == "defer":
                self._mode = "raise"
            if self._pending:
                self._pending = False
                raise KeyboardInterrupt("stopped")

    def _handle(self, signum: int, _frame: Optional[FrameType]) -> None:
        self.received += 1
        if self.received > 1:
            for action in self._kill_actions:
                try:
                    action()
                except Exception:  # noqa: BLE001  (the process ends now whatever an action did)
                    pass
            self._kill()
            return
        if self.say:
            # os.write, not print: the main thread may be inside a write to stderr right now.
            os.write(2, f"\n{self.say}\n".encode())
        if self._mode == "defer":
            self._mode, self._pending = "hold", True
        elif self._mode == "raise":
            self._mode = "hold"           # cleaning up must not be interrupted in turn
            raise KeyboardInterrupt(signal.Signals(signum).name)
