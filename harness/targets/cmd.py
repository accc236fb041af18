"""``cmd:<command line>``: a child process speaking the protocol on its stdin/stdout.

The command line is split like a shell would (shlex), but no shell runs it. Its stderr is
kept (the last lines) so that when it exits, the error says why: exit status and those
lines. The child gets its own process group, so closing the target ends its children too.
"""
from __future__ import annotations

import collections
import os
import select
import shlex
import signal
import subprocess
import threading
import time
from typing import Deque, List, Optional

from ...plumbing.parent_death import die_with_parent
from .base import NotReading, Target, TargetError

__all__ = ["CommandTarget", "from_url", "stop_process_group"]

_STDERR_LINES = 20


def stop_process_group(proc: subprocess.Popen, grace: float = 2.0) -> None:
    """SIGTERM the child's process group, then SIGKILL if it lingers; reaps the child."""
    if proc.poll() is None:
        for sig in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(proc.pid, sig)
            except (ProcessLookupError, PermissionError):
                break
            try:
                proc.wait(timeout=grace)
                break
            except subprocess.TimeoutExpired:
                continue
    try:
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        pass


class CommandTarget(Target):
    """A program as a HAT: bytes to its stdin, bytes from its stdout."""

    disposable = True        # the program (and its world) ends with the target

    def __init__(self, argv: List[str], url: str = "", env: Optional[dict] = None, cwd: Optional[str] = None):
        if not argv:
            raise TargetError("cmd: needs a command line, e.g. cmd:python3 my_fake_hat.py")
        self.argv = list(argv)
        self.url = url or "cmd:" + shlex.join(argv)
        self.env, self.cwd = env, cwd
        self.proc: Optional[subprocess.Popen] = None
        self.stderr_tail: Deque[str] = collections.deque(maxlen=_STDERR_LINES)
        self._stderr_thread: Optional[threading.Thread] = None

    def open(self) -> None:
        if self.is_open:
            return
        try:
            self.proc = subprocess.Popen(self.argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=subprocess.PIPE, bufsize=0, env=self.env, cwd=self.cwd,
                                         start_new_session=True, preexec_fn=die_with_parent())
        except FileNotFoundError:
            raise TargetError(f"{self.url}: command not found: {self.argv[0]!r}") from None
        except PermissionError:
            raise TargetError(f"{self.url}: not executable: {self.argv[0]!r}") from None
        except OSError as exc:
            raise TargetError(f"{self.url}: cannot start the command: {exc}") from exc
        # Writes never block: a child that stops reading is found out at the write deadline.
        assert self.proc.stdin is not None
        os.set_blocking(self.proc.stdin.fileno(), False)
        self._stderr_thread = threading.Thread(target=self._keep_stderr, name="cmd-target stderr",
                                               daemon=True)
        self._stderr_thread.start()
        self.is_open = True

    def _keep_stderr(self) -> None:
        assert self.proc is not None and self.proc.stderr is not None
        try:
            for raw in iter(self.proc.stderr.readline, b""):
                self.stderr_tail.append(raw.decode("utf-8", "replace").rstrip("\r\n"))
        except (ValueError, OSError):
            pass  # close() closed the pipe under us: nothing more to keep

    def _gone(self, what: str) -> TargetError:
        """The error for a child that stopped talking: exit status and its last stderr lines."""
        assert self.proc is not None
        try:
            status = self.proc.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            status = None
        if self._stderr_thread is not None:
            self._stderr_thread.join(timeout=1.0)
        if status is None:
            how = "is still running but closed its stdout"
        elif status < 0:
            how = f"was killed by signal {-status} ({signal.Signals(-status).name})"
        else:
            how = f"exited with status {status}"
        tail = "\n".join(f"  {line}" for line in self.stderr_tail)
        return TargetError(f"{self.url}: the command {how} ({what})" +
                           (f"; its last stderr lines:\n{tail}" if tail else "; it wrote nothing on stderr"))

    def write(self, data: bytes) -> None:
        """Write all of ``data`` to the child's stdin, or raise NotReading when it has not taken
        them within ``write_deadline`` seconds (its pipe full: it stopped reading)."""
        if self.proc is None or self.proc.stdin is None:
            raise TargetError(f"{self.url} is not open")
        fd = self.proc.stdin.fileno()
        view = memoryview(data)
        deadline = time.monotonic() + self.write_deadline
        try:
            while view:
                left = deadline - time.monotonic()
                _, ready, _ = select.select([], [fd], [], max(0.0, left))
                if not ready:
                    if self.proc.poll() is not None:
                        raise self._gone("while the host was writing")
                    raise NotReading(f"{self.url} stopped reading its input: {len(view):,} of {len(data):,} "
                                     f"bytes not taken in {self.write_deadline:g} s")
                try:
                    view = view[os.write(fd, view):]
                except BlockingIOError:
                    continue
        except (BrokenPipeError, ValueError, OSError):
            raise self._gone("while the host was writing") from None

    def read(self, timeout: float) -> bytes:
        if self.proc is None or self.proc.stdout is None:
            raise TargetError(f"{self.url} is not open")
        fd = self.proc.stdout.fileno()
        ready, _, _ = select.select([fd], [], [], max(0.0, timeout))
        if not ready:
            return b""
        data = os.read(fd, 65536)
        if not data:
            raise self._gone("its stdout closed")
        return data

    def close(self) -> None:
        self.is_open = False
        proc, self.proc = self.proc, None
        if proc is None:
            return
        for pipe in (proc.stdin,):
            try:
                if pipe is not None:
                    pipe.close()
            except OSError:
                pass
        stop_process_group(proc)
        for pipe in (proc.stdout, proc.stderr):
            try:
                if pipe is not None:
                    pipe.close()
            except OSError:
                pass

    def diagnose(self, problem: str) -> str:
        tail = "; its stderr so far: " + " | ".join(self.stderr_tail) if self.stderr_tail else ""
        if problem == "silent":
            return ("The command runs but printed nothing: does it answer 'version<CR>' on stdout, and flush "
                    "its output (e.g. python -u)?" + tail)
        if problem == "garbage":
            return "The command's stdout is not Build HAT protocol text." + tail
        return ""


def from_url(url: str, **options) -> CommandTarget:
    """``cmd:<command line>``; options ``env`` and ``cwd`` pass to the process."""
    line = url[len("cmd:"):].strip()
    try:
        argv = shlex.split(line)
    except ValueError as exc:
        raise TargetError(f"{url}: cannot split the command line: {exc}") from None
    env, cwd = options.pop("env", None), options.pop("cwd", None)
    if options:
        raise TargetError(f"{url}: options not understood here: {', '.join(sorted(options))}")
    return CommandTarget(argv, url=url, env=env, cwd=cwd)
