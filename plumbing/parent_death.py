"""Children that end with their parent: ``prctl(PR_SET_PDEATHSIG)`` on Linux, through ctypes.

Every process the harness starts (the suite's pytest child, the emulator, a ``cmd:`` target)
gets a signal when the process that started it dies, even by SIGKILL, so nothing is left
driving a HAT or holding a pty after ``buildhat-conformance`` is gone. Elsewhere (macOS)
this is a no-op and process groups do what they can.

The signal comes when the *thread* that forked the child ends: start children from a thread
that lives as long as they should (the main thread, in every caller here).
"""
from __future__ import annotations

import ctypes
import ctypes.util
import signal
import sys
from typing import Callable, Optional

__all__ = ["die_with_parent", "set_parent_death_signal"]

_PR_SET_PDEATHSIG = 1
_libc = None
if sys.platform.startswith("linux"):
    try:   # loaded here, in the parent: the child between fork and exec only makes the call
        _libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    except OSError:
        _libc = None


def set_parent_death_signal(sig: int = signal.SIGTERM) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent dies; True if it could."""
    if _libc is None:
        return False
    return _libc.prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0


def die_with_parent(sig: int = signal.SIGTERM,
                    then: Optional[Callable[[], None]] = None) -> Callable[[], None]:
    """A ``preexec_fn`` for subprocess/pexpect: set the parent-death signal, then run ``then``."""
    def preexec() -> None:
        set_parent_death_signal(sig)
        if then is not None:
            then()
    return preexec
