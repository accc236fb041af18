"""pytest plugin for host libraries' own tests: the ``buildhat_emulator`` fixture.

    def test_motor_runs(buildhat_emulator):
        ser = serial.Serial(buildhat_emulator.path, 115200)     # a real pty in raw mode
        buildhat_emulator.control("@pos 0 90")                  # world actions, see --help

    @pytest.mark.buildhat_emulator(firmware="R5", devices={3: "0x30", 1: None}, speed=1)
    def test_old_firmware(buildhat_emulator): ...

The fixture starts ``buildhat-emulator --pty --control <socket>`` as a child process, waits
until its control channel answers (and, unless ``settle=False``, until the start-up is done
and the devices are up), yields a :class:`EmulatorProcess`, and always stops the process
and removes its files. Marker arguments: ``firmware``, ``devices`` (port -> SPEC or None,
over the default layout), ``version_string``, ``speed``, ``baud``, ``bootloader``,
``settle``, ``args`` (extra command-line arguments).

The plugin adds no command-line options and imports only the standard library at load time.
"""
from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from typing import Any, Dict, List, Optional

import pytest

__all__ = ["EmulatorProcess", "buildhat_emulator", "START_TIMEOUT"]

START_TIMEOUT = 30.0     # wall seconds for the child to come up (slow CI machines)
MARKER = "buildhat_emulator"


class EmulatorProcess:
    """A running ``buildhat-emulator --pty`` child: its pty path and its control channel."""

    def __init__(self, firmware: Optional[str] = None, devices: Optional[Dict[int, Any]] = None,
                 version_string: Optional[str] = None, speed: float = 1.0, baud: Optional[int] = None,
                 bootloader: bool = False, args: Optional[List[str]] = None):
        self._dir = tempfile.mkdtemp(prefix="bhemu-")
        self.control_path = os.path.join(self._dir, "control.sock")
        cmd = [sys.executable, "-m", "buildhat_conformance.emulator.cli", "--pty",
               "--control", self.control_path, "--speed", str(speed)]
        if firmware is not None:
            cmd += ["--firmware", str(firmware)]
        for port, spec in (devices or {}).items():
            cmd += ["--device", f"{int(port)}={'none' if spec is None else spec}"]
        if version_string is not None:
            cmd += ["--version-string", version_string]
        if baud is not None:
            cmd += ["--baud", str(baud)]
        if bootloader:
            cmd.append("--bootloader")
        cmd += list(args or [])
        self.command = cmd
        self._stderr = open(os.path.join(self._dir, "stderr.txt"), "w+b")
        self.process = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self._stderr,
                                        stdin=subprocess.DEVNULL)
        self._sock: Optional[socket.socket] = None
        self._reply = b""
        try:
            self.path = self._first_line()
            self._connect()
            self.firmware = self.control("@firmware")[3:]
        except BaseException:
            self.close()
            raise

    def _failure(self, what: str) -> RuntimeError:
        self._stderr.seek(0)
        err = self._stderr.read().decode("utf-8", "replace").strip()
        return RuntimeError(f"buildhat-emulator {what} ({' '.join(self.command)})"
                            + (f":\n{err}" if err else ""))

    def _first_line(self) -> str:
        stdout = self.process.stdout
        assert stdout is not None          # Popen(stdout=PIPE)
        line = stdout.readline().decode("utf-8", "replace").strip()
        if not line:
            self.process.wait(5)
            raise self._failure(f"exited with status {self.process.returncode} before printing the pty path")
        return line

    def _connect(self) -> None:
        deadline = time.monotonic() + START_TIMEOUT
        while True:
            if self.process.poll() is not None:
                raise self._failure(f"exited with status {self.process.returncode}")
            try:
                sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                sock.settimeout(START_TIMEOUT)
                sock.connect(self.control_path)
                self._sock = sock
                return
            except OSError:
                sock.close()
                if time.monotonic() > deadline:
                    raise self._failure("control channel did not come up") from None
                time.sleep(0.02)

    def control(self, line: str) -> str:
        """Send one control request (e.g. ``@plug 1 0x30``); returns the reply line (``ok ...``)."""
        if self._sock is None:
            raise RuntimeError("the emulator is not running")
        self._sock.sendall(line.strip().encode("utf-8") + b"\n")
        while b"\n" not in self._reply:
            chunk = self._sock.recv(4096)
            if not chunk:
                raise self._failure("closed the control channel")
            self._reply += chunk
        reply, _, self._reply = self._reply.partition(b"\n")
        return reply.decode("utf-8")

    def wait_settled(self, timeout: float = START_TIMEOUT) -> None:
        """Wait (wall time) until the start-up is done and the devices are up."""
        deadline = time.monotonic() + timeout
        while self.control("@settled") != "ok 1":
            if time.monotonic() > deadline:
                raise self._failure("did not finish starting up")
            time.sleep(0.02)

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(5)
        if self.process.stdout is not None:
            self.process.stdout.close()
        self._stderr.close()
        shutil.rmtree(self._dir, ignore_errors=True)

    def __enter__(self) -> EmulatorProcess:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def pytest_configure(config: Any) -> None:
    config.addinivalue_line(
        "markers", f"{MARKER}(firmware=None, devices=None, speed=1.0, ...): options for the "
        "buildhat_emulator fixture (see buildhat_conformance.emulator.pytest_fixture)")


@pytest.fixture
def buildhat_emulator(request: Any):
    """A ``buildhat-emulator --pty`` child process (see the module docstring)."""
    marker = request.node.get_closest_marker(MARKER)
    options = dict(marker.kwargs) if marker else {}
    settle = options.pop("settle", True)
    emulator = EmulatorProcess(**options)
    try:
        if settle and not options.get("bootloader"):
            emulator.wait_settled()
        yield emulator
    finally:
        emulator.close()
