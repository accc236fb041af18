"""A ``buildhat-emulator --pty`` child process as the pytest fixtures
(emulator/host_fixtures/pytest_plugin.py) run it.

Standard library only at import time: this runs inside a host library's own test environment. The
emulator itself is started as ``BUILDHAT_EMULATOR`` says (a command line, e.g. the ``buildhat-emulator``
of another venv) or else with this interpreter (``python -m buildhat_conformance.emulator.cli``).

Every run writes a JSONL transcript (``--output``) and the emulator's stderr (the host-lint report,
a ``--strict-host`` stop) into ``keep_dir``, so a failed test can show them and keep them.
"""
from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from typing import Any, Dict, List, Optional, Tuple

from ...serving.control_client import ENV_ADDRESS, ControlClient, ControlError

__all__ = ["EmulatorProcess", "START_TIMEOUT", "ENV_COMMAND"]

START_TIMEOUT = 30.0     # wall seconds for the child to come up (slow CI machines)
ENV_COMMAND = "BUILDHAT_EMULATOR"


def _emulator_command() -> List[str]:
    configured = os.environ.get(ENV_COMMAND, "").strip()
    if configured:
        return shlex.split(configured)
    return [sys.executable, "-m", "buildhat_conformance.emulator.cli"]


class EmulatorProcess:
    """A running ``buildhat-emulator --pty`` child: its pty path, control channel, transcript and stderr."""

    def __init__(self, firmware: Optional[str] = None, devices: Optional[Dict[int, Any]] = None,
                 version_string: Optional[str] = None, speed: float = 1.0, baud: Optional[int] = None,
                 bootloader: bool = False, args: Optional[List[str]] = None, keep_dir: Optional[str] = None,
                 link: Optional[str] = None, fast_setup: bool = False):
        # The socket lives in a short private directory (a Unix socket path has ~100 bytes at most).
        self._dir = tempfile.mkdtemp(prefix="bhemu-")
        self.keep_dir = keep_dir or self._dir
        os.makedirs(self.keep_dir, exist_ok=True)
        self.control_path = os.path.join(self._dir, "control.sock")
        self.transcript_path = os.path.join(self.keep_dir, "transcript.jsonl")
        self.stderr_path = os.path.join(self.keep_dir, "emulator-stderr.txt")
        self.devices = dict(devices or {})
        cmd = _emulator_command() + ["--pty", "--control", self.control_path, "--speed", str(speed),
                                     "--output", self.transcript_path]
        if link is not None:
            cmd += ["--link", link]
        if firmware is not None:
            cmd += ["--firmware", str(firmware)]
        for port, spec in self.devices.items():
            cmd += ["--device", f"{int(port)}={'none' if spec is None else spec}"]
        if version_string is not None:
            cmd += ["--version-string", version_string]
        if baud is not None:               # else the emulator's own default: a HAT's 115200-baud wire
            cmd += ["--baud", str(baud)]
        if fast_setup:                     # devices set up faster than a HAT's 2400 baud
            cmd.append("--fast-setup")
        if bootloader:
            cmd.append("--bootloader")
        cmd += list(args or [])
        self.command = cmd
        self._stderr = open(self.stderr_path, "w+b")
        self._undo: List[Tuple[str, str]] = []      # (request made, request that undoes it)
        self._client: Optional[ControlClient] = None
        self.process = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self._stderr,
                                        stdin=subprocess.DEVNULL)
        try:
            self.path = self._first_line()
            self.link = link
            self._client = ControlClient(self.control_path, timeout=START_TIMEOUT)
            self._client.connect(wait=START_TIMEOUT)
            self.firmware = self.control("@firmware")[3:]
        except BaseException:
            self.close()
            raise

    # -- what a client needs ---------------------------------------------------------------------------
    def environment(self) -> Dict[str, str]:
        """What a library's process needs to reach this emulator (the gpiozero pin factory reads it)."""
        return {ENV_ADDRESS: self.control_path}

    def control(self, line: str) -> str:
        """Send one control request (e.g. ``@plug 1 0x30``); returns the reply line (``ok ...``)."""
        if self._client is None:
            raise RuntimeError("the emulator is not running")
        try:
            reply = self._client.request(line)
        except ControlError as exc:
            raise self.failure(str(exc)) from None
        undo = _undo_of(line.split(), self.devices)
        if reply.startswith("ok") and undo is not None:
            self._undo.append((line.strip(), undo))
        return reply

    def restore(self) -> List[str]:
        """Undo, newest first, what :meth:`control` changed in the world (readings, held shafts, faults,
        plugged devices, Vin); returns the requests sent. Shaft positions stay, as on a HAT."""
        sent: List[str] = []
        undo_log, self._undo = self._undo, []
        for _, undo in reversed(undo_log):
            if self._client is None or not self.alive():
                break
            reply = self._client.request(undo)
            if not reply.startswith("ok"):
                raise self.failure(f"refused {undo!r} while restoring the world: {reply}")
            sent.append(undo)
        return sent

    def wait_settled(self, timeout: float = START_TIMEOUT) -> None:
        """Wait (wall time) until the start-up is done and the devices are up."""
        deadline = time.monotonic() + timeout
        while self.control("@settled") != "ok 1":
            if time.monotonic() > deadline:
                raise self.failure("did not finish starting up")
            time.sleep(0.02)

    def alive(self) -> bool:
        return self.process.poll() is None

    # -- what a failed test shows -----------------------------------------------------------------------
    def lint(self) -> Optional[Dict[str, Any]]:
        """The ``@lint`` summary, or None once the emulator has gone."""
        if not self.alive() or self._client is None:
            return None
        try:
            reply = self._client.request("@lint")
        except ControlError:
            return None
        try:
            return json.loads(reply[3:]) if reply.startswith("ok ") else None
        except ValueError:
            return None

    def stderr_text(self) -> str:
        self._stderr.flush()
        try:
            with open(self.stderr_path, "rb") as handle:
                return handle.read().decode("utf-8", "replace")
        except OSError:
            return ""

    def details(self, since_line: int = 0) -> str:
        """For a failure message: the lint findings from host line ``since_line + 1`` on, the emulator's
        exit and stderr (a ``--strict-host`` stop names the line), and where the transcript is."""
        out: List[str] = []
        summary = self.lint()
        if summary is not None:
            mine = [f for f in summary.get("findings", []) if int(f.get("line", 0)) > since_line]
            out.append(f"host lint: {len(mine)} finding(s) in this test ({summary.get('lines')} host lines "
                       "in the session)" + (":" if mine else ""))
            out += [f"  line {f['line']} (t={f['t']} ms) {f['text']!r}: {f['kind']}: {f['detail']}"
                    for f in mine]
        else:
            out.append(f"buildhat-emulator exited with status {self.process.poll()}")
        err = self.stderr_text().strip()
        if err:
            out.append("emulator stderr:")
            out += ["  " + line for line in err.splitlines()[-25:]]
        out.append(f"transcript (every byte both ways, lint findings as notes): {self.transcript_path}")
        return "\n".join(out)

    def failure(self, what: str) -> RuntimeError:
        err = self.stderr_text().strip()
        return RuntimeError(f"buildhat-emulator {what} ({' '.join(self.command)})"
                            + (f":\n{err}" if err else ""))

    # -- start and stop ---------------------------------------------------------------------------------
    def _first_line(self) -> str:
        assert self.process.stdout is not None
        line = self.process.stdout.readline().decode("utf-8", "replace").strip()
        if not line:
            self.process.wait(5)
            raise self.failure(f"exited with status {self.process.returncode} before printing the pty path")
        return line

    def close(self, keep: bool = False) -> None:
        """Stop the child; its transcript and stderr stay in ``keep_dir`` when ``keep``."""
        if self._client is not None:
            self._client.close()
            self._client = None
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
        if not keep and self.keep_dir != self._dir:
            shutil.rmtree(self.keep_dir, ignore_errors=True)

    def __enter__(self) -> EmulatorProcess:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _undo_of(words: List[str], devices: Dict[int, Any]) -> Optional[str]:
    """The request that puts back what ``words`` changed, or None (nothing to undo, or a query)."""
    if len(words) < 2:
        return None
    head, port = words[0], words[1]
    if head == "@data" and len(words) >= 4 and words[3] != "auto":
        return f"@data {port} {words[2]} auto"
    if head == "@hold":
        return f"@hold {port} 0"
    if head == "@button":
        return f"@button {port} 0"
    if head == "@motorfault" and port == "1" and len(words) >= 3:
        return f"@motorfault 0 {words[2]}"
    if head == "@portfault" and port == "1":
        return "@portfault 0"
    if head == "@adc":
        from ..api import DEFAULT_ADC  # (emulator/hat.py is for the composition roots only)
        return f"@adc {DEFAULT_ADC}"
    if head in ("@plug", "@unplug") and port.isdigit():
        from ...protocol.devices import DEFAULT_LAYOUT
        spec = devices[int(port)] if int(port) in devices else _spec_text(DEFAULT_LAYOUT.get(int(port)))
        return f"@unplug {port}" if spec in (None, "none") else f"@plug {port} {spec}"
    return None


def _spec_text(spec: Any) -> Optional[str]:
    """A DEFAULT_LAYOUT entry (("active", 0x30) / ("passive", 8) / None) as a device SPEC."""
    if spec is None:
        return None
    kind, value = spec
    return f"0x{value:02X}" if kind == "active" else f"passive {value}"
