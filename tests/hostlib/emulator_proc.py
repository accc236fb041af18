"""``buildhat-emulator --pty --control SOCKET`` as a child process, for host-library tests.

Follows the process contract of docs/DEVELOPING.md: the first stdout line is the pty's slave path, the
control channel takes one scenario-script action per line and answers one line (``ok [value]`` or
``error <message>``). On exit the emulator writes its host-lint report to stderr.
"""
from __future__ import annotations

import os
import pathlib
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from typing import Dict, List, Optional

__all__ = ["EmulatorProcess", "EmulatorFailed", "emulator_command"]


class EmulatorFailed(RuntimeError):
    """The emulator did not start, or a control action was refused."""


def emulator_command() -> List[str]:
    """The ``buildhat-emulator`` console script of the running interpreter's environment."""
    beside = pathlib.Path(sys.executable).with_name("buildhat-emulator")
    if beside.exists():
        return [str(beside)]
    found = shutil.which("buildhat-emulator")
    if found:
        return [found]
    return [sys.executable, "-c", "import sys; from buildhat_conformance.emulator.cli import main; "
                                  "sys.exit(main())"]


class EmulatorProcess:
    """One emulator on a pty. Use as a context manager; ``stop()`` returns the exit code."""

    def __init__(self, firmware: Optional[str] = None, devices: Optional[Dict[int, str]] = None,
                 bootloader: bool = False, speed: Optional[float] = None, strict_host: bool = False,
                 extra: Optional[List[str]] = None):
        self.tmp = pathlib.Path(tempfile.mkdtemp(prefix="bh-emu-"))
        self.control_path = str(self.tmp / "control.sock")
        args = emulator_command() + ["--pty", "--control", self.control_path]
        if firmware is not None:
            args += ["--firmware", str(firmware)]
        for port, spec in sorted((devices or {}).items()):
            args += ["--device", f"{port}={spec}"]
        if bootloader:
            args.append("--bootloader")
        if speed is not None:
            args += ["--speed", str(speed)]
        if strict_host:
            args.append("--strict-host")
        self.args = args + list(extra or [])
        self.proc: Optional[subprocess.Popen] = None
        self.pty: str = ""
        self.stderr_path = self.tmp / "stderr.txt"
        self.returncode: Optional[int] = None

    # -- life cycle --------------------------------------------------------------------------------------
    def start(self, timeout: float = 15.0) -> EmulatorProcess:
        self._stderr = open(self.stderr_path, "wb")
        # Own session: stop() can end the emulator and anything it started, and nothing else.
        self.proc = subprocess.Popen(self.args, stdout=subprocess.PIPE, stderr=self._stderr,
                                     stdin=subprocess.DEVNULL, start_new_session=True)
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        line = self.proc.stdout.readline().decode(errors="replace").strip() if ready else ""
        if not line:
            self.stop()
            raise EmulatorFailed(f"no pty path on stdout within {timeout} s; command {self.args}; "
                                 f"stderr:\n{self.stderr()}")
        self.pty = line
        deadline = time.monotonic() + timeout
        while not os.path.exists(self.control_path):
            if time.monotonic() > deadline or self.proc.poll() is not None:
                self.stop()
                raise EmulatorFailed(f"control socket {self.control_path} never appeared; "
                                     f"stderr:\n{self.stderr()}")
            time.sleep(0.02)
        return self

    def stop(self, grace: float = 5.0) -> int:
        """SIGTERM (the emulator then reports its lint and exits), SIGKILL after ``grace`` seconds."""
        if self.proc is None:
            return -1
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGTERM)
                self.proc.wait(timeout=grace)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
            except ProcessLookupError:
                pass
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self._stderr.close()
        self.returncode = returncode = self.proc.wait()    # already ended: its status at once
        return returncode

    def wait(self, timeout: float) -> Optional[int]:
        """Wait for the emulator to exit by itself (e.g. ``--strict-host``); None if it did not."""
        assert self.proc is not None
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return None

    def stderr(self) -> str:
        try:
            return self.stderr_path.read_text(errors="replace")
        except OSError:
            return ""

    def __enter__(self) -> EmulatorProcess:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
        shutil.rmtree(self.tmp, ignore_errors=True)

    # -- control channel ---------------------------------------------------------------------------------
    def control(self, line: str, timeout: float = 10.0) -> str:
        """Send one action; return the reply text after ``ok`` ('' for a bare ``ok``).
        Raises EmulatorFailed on ``error ...`` so a refused action can never pass unnoticed."""
        reply = self.control_raw(line, timeout)
        if reply == "ok":
            return ""
        if reply.startswith("ok "):
            return reply[3:]
        raise EmulatorFailed(f"control {line!r} -> {reply!r}")

    def control_raw(self, line: str, timeout: float = 10.0) -> str:
        deadline = time.monotonic() + timeout
        while True:
            try:
                return self._request(line, timeout)
            except (ConnectionRefusedError, FileNotFoundError):
                # The socket file appears at bind(), a moment before listen(): retry until it listens.
                if time.monotonic() > deadline or (self.proc is not None and self.proc.poll() is not None):
                    raise
                time.sleep(0.02)

    def _request(self, line: str, timeout: float) -> str:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
            sock.settimeout(timeout)
            sock.connect(self.control_path)
            sock.sendall(line.encode() + b"\n")
            data = b""
            while not data.endswith(b"\n"):
                chunk = sock.recv(65536)
                if not chunk:
                    break
                data += chunk
        return data.decode(errors="replace").strip()

    def hat_time(self) -> int:
        return int(self.control("@time"))

    def wait_settled(self, hat_ms: int = 5000, timeout: float = 30.0) -> None:
        """Wait until the start-up is done and the devices are up (``@settled``), so a host does not
        talk too early. An emulator without ``@settled`` is waited for by HAT time (``hat_ms``)."""
        deadline = time.monotonic() + timeout
        while True:
            reply = self.control_raw("@settled")
            if reply == "ok 1":
                return
            if reply.startswith("error") and self.hat_time() >= hat_ms:
                return
            if time.monotonic() > deadline:
                raise EmulatorFailed(f"not settled within {timeout} s (last reply {reply!r}); "
                                     f"stderr:\n{self.stderr()}")
            time.sleep(0.02)
