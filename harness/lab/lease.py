"""Holding one labgrid place for one run, and giving it back on every way out.

labgrid's lock is per host and user: two runs of the same user on the same machine look alike to
the coordinator, and a run killed outright (SIGKILL, power loss) leaves its place acquired. So a
run also holds a lock file of this machine (``flock``, which the kernel drops when the process
dies) recording whether the run acquired the place itself:

- lock file busy: another live run of this machine has the place -> :class:`PlaceHeld`;
- place free: acquire it; released at the end;
- place acquired by this host/user and the lock file says a run acquired it: that run was
  killed; take it over (one line says so) and release it at the end;
- place acquired by this host/user and no run did it: the user acquired it by hand
  (``labgrid-client acquire``); use it and leave it acquired;
- place acquired by anyone else: :class:`PlaceHeld`, one line naming the holder and the command
  that frees it.

A run hands its places to its own children (the pytest child, its xdist workers) through
``BUILDHAT_LAB_HOLDER`` (its pid): a child finding the lock held by that pid uses the place and
leaves acquire and release to the run.
"""
from __future__ import annotations

import atexit
import errno
import fcntl
import json
import os
import re
import signal
import sys
import threading
import time
from typing import Any, Callable, Dict, Optional

from ..targets.base import TargetError
from .client import LabClient, PlaceHeld

__all__ = ["PlaceLease", "HOLDER_ENV", "holder_env", "lock_dir", "POLL_S"]

HOLDER_ENV = "BUILDHAT_LAB_HOLDER"
POLL_S = 0.5              # how often a waiting run looks again (a person's lab, not a race)


def lock_dir() -> str:
    """Per user and machine, kept across reboots (a place left acquired outlives them too)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "buildhat-conformance", "labgrid")


def _say(line: str) -> None:
    print(f"buildhat-conformance: {line}", file=sys.stderr, flush=True)


class PlaceLease:
    """The run's hold on place ``name``. :meth:`take` (waiting up to ``wait`` seconds for a held
    place), :meth:`give_back` (safe to call twice; also at exit and on SIGTERM)."""

    def __init__(self, client: LabClient, name: str, wait: float = 0.0, say: Callable[[str], None] = _say):
        self.client, self.name, self.wait, self.say = client, name, float(wait), say
        safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{client.address}-{name}")
        self.path = os.path.join(lock_dir(), safe + ".lock")
        self._fd: Optional[int] = None
        self.acquired = False        # we acquired it, so we release it
        self.inherited = False       # our run holds it for us
        self.held = False

    # -- taking ----------------------------------------------------------------------------
    def take(self) -> None:
        deadline = time.monotonic() + max(0.0, self.wait)
        while True:
            try:
                self._try()
                break
            except PlaceHeld:
                if time.monotonic() >= deadline:
                    raise
                time.sleep(POLL_S)
        self.held = True
        atexit.register(self.give_back)
        _release_on_sigterm()

    def _try(self) -> None:
        os.makedirs(os.path.dirname(self.path), exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            record = self._read(fd)
            os.close(fd)
            if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise TargetError(f"cannot lock {self.path}: {exc}") from None
            holder = os.environ.get(HOLDER_ENV, "")
            if holder and str(record.get("pid")) == holder:
                self.inherited = True          # our own run holds it for us
                return
            raise PlaceHeld(f"place {self.name} is held by another run on this machine "
                            f"(pid {record.get('pid', '?')}); wait for it (--lab-wait SECONDS)") from None
        self._fd = fd
        try:
            self._acquire(self._read(fd))
        except BaseException:
            self._unlock()
            raise

    def _acquire(self, record: Dict[str, Any]) -> None:
        state = self.client.place(self.name)
        if state.acquired and state.acquired != self.client.me:
            raise PlaceHeld(self.client.held_text(state))
        if state.acquired:
            if record.get("acquired"):
                self.say(f"place {self.name} was left acquired by a run that was killed (pid "
                         f"{record.get('pid', '?')}); this run takes it over and releases it at the end")
                self.acquired = True
            self._write({"pid": os.getpid(), "acquired": self.acquired})
            return
        # Written first: a run killed between the two still leaves a record that it acquired.
        self._write({"pid": os.getpid(), "acquired": True})
        try:
            self.client.acquire(self.name)
        except BaseException:
            self._write({"pid": None, "acquired": False})
            raise
        self.acquired = True

    # -- giving back -----------------------------------------------------------------------
    def give_back(self) -> None:
        if not self.held:
            return
        self.held = False
        if self.inherited:
            return
        try:
            if self.acquired:
                self.client.release(self.name)
                self._write({"pid": None, "acquired": False})
        except TargetError as exc:
            self.say(f"{exc} (free it with 'labgrid-client -x {self.client.address} -p {self.name} "
                     "release')")
        finally:
            self._unlock()

    def _unlock(self) -> None:
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)            # drops the flock

    # -- the lock file ---------------------------------------------------------------------
    @staticmethod
    def _read(fd: int) -> Dict[str, Any]:
        try:
            os.lseek(fd, 0, os.SEEK_SET)
            found = json.loads(os.read(fd, 4096).decode() or "{}")
        except (OSError, ValueError):
            return {}
        return found if isinstance(found, dict) else {}

    def _write(self, record: Dict[str, Any]) -> None:
        if self._fd is None:
            return
        data = json.dumps(record).encode()
        os.lseek(self._fd, 0, os.SEEK_SET)
        os.ftruncate(self._fd, 0)
        os.write(self._fd, data)
        os.fsync(self._fd)


_TERM_INSTALLED: list = []


def _release_on_sigterm() -> None:
    """SIGTERM's default ends the process without ``atexit``: turn it into KeyboardInterrupt, so
    the run unwinds and gives its places back. Left alone when a handler is set already (the
    suite's own, conformance/plugin/interrupt.py) or off the main thread."""
    if _TERM_INSTALLED or threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
        def on_term(_sig: int, _frame: Any) -> None:
            raise KeyboardInterrupt
        signal.signal(signal.SIGTERM, on_term)
    _TERM_INSTALLED.append(True)


def holder_env() -> Dict[str, str]:
    """The environment a run gives its children so they use its places (see module docstring)."""
    return {HOLDER_ENV: str(os.getpid())}
