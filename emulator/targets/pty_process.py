"""``emulator`` / ``emulator:<release|latest>[?speed=N&device=P=SPEC&...]``: the reference
emulator as a separate process on a pty, with its out-of-band control channel.

The target spawns ``buildhat-emulator --pty --control <unix socket in a temp dir>
--firmware ... [--speed N] [--device P=SPEC ...]`` with pexpect, reads the pty path from
the emulator's first stdout line, opens it with pyserial and attaches an
:class:`EmulatorControl` (the one control client, serving/control_client.py). The emulator's
stderr goes to a file in the temp dir so that when it fails (to start, or later) the error carries
the emulator's own words.
"""
from __future__ import annotations

import collections
import os
import select
import shlex
import shutil
import signal
import sys
import tempfile
import threading
import time
from typing import Any, Deque, Dict, FrozenSet, List, Optional, Sequence, Union
from urllib.parse import parse_qs, urlsplit

import pexpect
import serial

from ...harness.targets.base import Control, TargetError
from ...harness.targets.pyserial_base import PyserialTarget, SerialPort
from ...plumbing.parent_death import die_with_parent
from ...protocol.devices import DEFAULT_LAYOUT, format_device_spec, parse_device_spec
from ...serving.control_client import ControlClient, ControlError
from ...transcripts.script import WORLD_ACTIONS

__all__ = ["EmulatorTarget", "EmulatorControl", "from_url", "emulator_command", "format_device_spec"]

# The world actions, plus the control requests of DEVELOPING.md (@reset, @time, @speed, @drive_events, ...).
CONTROL_CAPABILITIES: FrozenSet[str] = frozenset(WORLD_ACTIONS) | {
    "reset", "bootloader", "layout", "time", "lint", "speed", "firmware", "drive_events", "device_frames",
    "faultpulse"}
_STARTUP_TIMEOUT = 20.0     # generous: two shared noisy cores, and a Python start-up
_REPLY_TIMEOUT = 10.0


def emulator_command(command: Union[str, Sequence[str], None] = None) -> List[str]:
    """The argv that starts the emulator: ``command`` if given, else $BUILDHAT_EMULATOR, else
    the ``buildhat-emulator`` installed beside this Python, else the one on PATH."""
    if command:
        return shlex.split(command) if isinstance(command, str) else list(command)
    env = os.environ.get("BUILDHAT_EMULATOR")
    if env:
        return shlex.split(env)
    beside = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
    if os.access(beside, os.X_OK):
        return [beside]
    found = shutil.which("buildhat-emulator")
    if found:
        return [found]
    raise TargetError("buildhat-emulator not found: install this package (pip install -e . in a "
                      "checkout, or pip install the built wheel) or set BUILDHAT_EMULATOR to the command "
                      "that starts it")


class EmulatorControl(Control):
    """The emulator's control channel as a harness Control: the one client (serving/control_client.py)
    underneath, its failures and ``error`` replies raised as TargetError naming the request."""

    def __init__(self, address: str, speed: float = 1.0, token: Optional[str] = None,
                 timeout: float = _REPLY_TIMEOUT):
        self.path = address
        self.capabilities = CONTROL_CAPABILITIES
        self.client = ControlClient(address, token=token, timeout=timeout)
        self._speed = float(speed)

    def connect(self, deadline: float) -> None:
        """Connect, retrying until the monotonic ``deadline`` while the emulator is still starting."""
        try:
            self.client.connect(wait=max(0.0, deadline - time.monotonic()))
        except ControlError as exc:
            raise TargetError(str(exc)) from None

    def request(self, line: str) -> str:
        """Send one request; returns the reply's value (text after ``ok``)."""
        if not self.client.connected:
            raise TargetError("the emulator's control channel is not connected")
        try:
            return self.client.value(line)
        except ControlError as exc:
            raise TargetError(str(exc)) from None

    def action(self, line: str) -> str:
        reply = self.request(line)
        words = line.split()
        if words and words[0] == "@speed" and reply:
            self._speed = float(reply)
        return reply

    def drive_events_since(self, t: int) -> List[Dict[str, Any]]:
        """The motor-drive changes after HAT ms ``t``, each port's level at ``t`` first."""
        if not self.client.connected:
            raise TargetError("the emulator's control channel is not connected")
        try:
            return self.client.drive_events_since(t)
        except ControlError as exc:
            raise TargetError(str(exc)) from None

    def device_frames_since(self, t: int) -> List[Dict[str, Any]]:
        """The frames the devices received from HAT ms ``t`` on (``dev`` events, as the in-process
        targets' ``device_frames``)."""
        if not self.client.connected:
            raise TargetError("the emulator's control channel is not connected")
        try:
            return self.client.device_frames_since(t)
        except ControlError as exc:
            raise TargetError(str(exc)) from None

    def refresh_speed(self) -> None:
        try:
            self._speed = float(self.request("@speed"))
        except (TargetError, ValueError):
            pass  # a runner without @speed keeps the speed it was started with

    @property
    def time_scale(self) -> float:
        return self._speed

    def reset(self, bootloader: bool = False) -> None:
        self.request("@reset bootloader" if bootloader else "@reset")

    def close(self) -> None:
        self.client.close()


class EmulatorTarget(PyserialTarget):
    """The emulator in its own process, reached through a pty like a real serial port."""

    disposable = True        # the process (and its world) ends with the target

    def __init__(self, url: str = "emulator", firmware: Union[str, int, None] = None,
                 speed: Optional[float] = None, devices: Optional[Dict[int, Optional[tuple]]] = None,
                 bootloader: bool = False, seed: Optional[int] = None, version_string: Optional[str] = None,
                 baud: Optional[int] = None, extra_args: Sequence[str] = (),
                 command: Union[str, Sequence[str], None] = None, startup_timeout: float = _STARTUP_TIMEOUT,
                 booted: bool = False, hang_after: Optional[int] = None, fast_setup: bool = False):
        super().__init__(url)
        self.firmware = "latest" if firmware in (None, "") else str(firmware)
        self.speed = speed
        self.devices = dict(devices or {})
        self.layout = dict(DEFAULT_LAYOUT)
        self.layout.update(self.devices)
        self.bootloader, self.seed, self.version_string = bootloader, seed, version_string
        self.booted = booted
        self.hang_after = hang_after      # fault injection: the firmware hangs after this many lines
        if booted and bootloader:
            raise TargetError(f"{url}: booted starts the firmware; it cannot be combined with bootloader")
        self.wire_baud = baud
        self.fast_setup = fast_setup      # devices set up faster than a HAT's 2400 baud
        self.extra_args = list(extra_args)
        self.command = command
        self.startup_timeout = startup_timeout
        # known before open, so a script runner can refuse a run before anything is sent
        self.capabilities = frozenset({"control"}) | CONTROL_CAPABILITIES
        self.child: Optional[pexpect.spawn] = None
        self.pty_path: Optional[str] = None
        self.control: Optional[EmulatorControl] = None
        self._tmp: Optional[str] = None
        self._stdout_tail: Deque[str] = collections.deque(maxlen=20)
        self._stop_drain = threading.Event()
        self._child_lock = threading.Lock()   # isalive() reaps: one thread at a time

    # -- process --------------------------------------------------------------------------------
    def argv(self, control_path: str) -> List[str]:
        args = emulator_command(self.command) + ["--pty", "--control", control_path,
                                                 "--firmware", self.firmware]
        if self.speed is not None:
            args += ["--speed", f"{self.speed:g}"]
        for port in sorted(self.devices):
            args += ["--device", f"{port}={format_device_spec(self.devices[port])}"]
        if self.bootloader:
            args.append("--bootloader")
        if self.booted:
            args.append("--booted")
        if self.seed is not None:
            args += ["--seed", str(self.seed)]
        if self.version_string is not None:
            args += ["--version-string", self.version_string]
        if self.wire_baud is not None:
            args += ["--baud", str(self.wire_baud)]
        elif self.command is None:
            # The suite's own emulator keeps its unpaced link unless the URL asks for the wire
            # (buildhat-emulator --pty alone paces at a HAT's 115200 baud).
            args += ["--baud", "0"]
        if self.fast_setup:
            args.append("--fast-setup")
        if self.hang_after is not None:
            args += ["--hang-after", str(self.hang_after)]
        return args + self.extra_args

    @property
    def stderr_path(self) -> Optional[str]:
        return os.path.join(self._tmp, "stderr.txt") if self._tmp else None

    def stderr_text(self, last: int = 20) -> str:
        """The emulator's last stderr lines (its own error messages)."""
        path = self.stderr_path
        if not path or not os.path.exists(path):
            return ""
        with open(path, encoding="utf-8", errors="replace") as fh:
            lines = fh.read().splitlines()
        return "\n".join(lines[-last:])

    def _make_port(self) -> SerialPort:
        self._stop_drain.clear()
        self._tmp = tempfile.mkdtemp(prefix="buildhat-emu-")
        control_path = os.path.join(self._tmp, "control.sock")
        stderr_path = self.stderr_path
        assert stderr_path is not None            # _tmp is set
        argv = self.argv(control_path)

        def send_stderr_to_file() -> None:  # runs in the child: keep stderr apart from the pty
            fd = os.open(stderr_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
            os.dup2(fd, 2)
            os.close(fd)

        try:
            self.child = pexpect.spawn(argv[0], argv[1:], encoding=None, echo=False,
                                       timeout=self.startup_timeout,
                                       # the emulator ends with this process, even if it is SIGKILLed
                                       preexec_fn=die_with_parent(then=send_stderr_to_file))
        except pexpect.ExceptionPexpect as exc:
            raise TargetError(f"cannot start the emulator ({shlex.join(argv)}): {exc}") from None
        deadline = time.monotonic() + self.startup_timeout
        try:
            self.child.expect(rb"\r?\n")
        except pexpect.EOF:
            raise TargetError(self._failed("exited before printing its pty path", argv)) from None
        except pexpect.TIMEOUT:
            raise TargetError(self._failed(f"printed no pty path within {self.startup_timeout:g} s", argv)) \
                from None
        before = self.child.before
        first = before.decode("utf-8", "replace").strip() if isinstance(before, bytes) else ""
        if not first or not os.path.exists(first):
            raise TargetError(self._failed(f"printed {first!r} where its pty path belongs", argv))
        self.pty_path = first
        threading.Thread(target=self._drain_stdout, name="emulator stdout", daemon=True).start()
        self.control = EmulatorControl(control_path, speed=self.speed or 1.0)
        self.control.connect(deadline)
        self.control.refresh_speed()
        settings = self.port_settings()
        port = serial.Serial(None, **settings)
        port.port = self.pty_path
        return port

    def open(self) -> None:
        try:
            super().open()
        except BaseException:
            self.close()
            raise

    def _drain_stdout(self) -> None:
        # Anything after the pty line must be read, or a chatty emulator blocks on a full pty.
        # Plain os.read on the fd: pexpect calls are not thread-safe (isalive() reaps).
        child = self.child
        fd = child.child_fd if child is not None else -1
        while fd >= 0 and not self._stop_drain.is_set():
            try:
                ready, _, _ = select.select([fd], [], [], 0.5)
                if not ready:
                    continue
                data = os.read(fd, 4096)
            except (OSError, ValueError):
                return   # EIO once the emulator has exited, EBADF once closed
            if not data:
                return
            self._stdout_tail.extend(data.decode("utf-8", "replace").splitlines())

    def _alive(self, child: pexpect.spawn) -> bool:
        with self._child_lock:
            try:
                return bool(child.isalive())
            except Exception:  # noqa: BLE001 - ptyprocess raises if the pid was reaped elsewhere
                return False

    def _status(self) -> str:
        child = self.child
        if child is None:
            return "did not start"
        if self._alive(child):
            # give a dying process a moment, so the status and stderr are complete
            for _ in range(20):
                time.sleep(0.05)
                if not self._alive(child):
                    break
            else:
                return "still running"
        if child.signalstatus:
            return f"killed by signal {child.signalstatus}"
        return f"exit status {child.exitstatus}"

    def _failed(self, what: str, argv: Sequence[str]) -> str:
        status = self._status()
        err = self.stderr_text()
        return (f"the emulator failed to start: it {what} ({status}).\n"
                f"command: {shlex.join(argv)}\n" +
                (f"its stderr:\n{err}" if err else "it wrote nothing on stderr"))

    def _explain(self, exc: BaseException) -> str:
        return f"cannot open the emulator's pty {self.pty_path}: {exc}"

    def _lost(self, exc: BaseException) -> str:
        status = self._status()
        err = self.stderr_text()
        return (f"the emulator went away ({exc}; {status})." +
                (f"\nits stderr:\n{err}" if err else ""))

    def close(self) -> None:
        super().close()
        if self.control is not None:
            self.control.close()
        self._stop_drain.set()
        child, self.child = self.child, None
        if child is not None and child.pid is not None:
            for sig in (signal.SIGTERM, signal.SIGKILL):
                try:
                    os.killpg(child.pid, sig)  # the emulator leads its own session (pty fork)
                except (ProcessLookupError, PermissionError):
                    break
                end = time.monotonic() + 3.0
                while self._alive(child) and time.monotonic() < end:
                    time.sleep(0.02)
                if not self._alive(child):
                    break
            try:
                child.close(force=True)
            except Exception:  # noqa: BLE001 - best effort; the process group is already gone
                pass
        if self._tmp:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    # -- what only the world sees (conformance/needs.py's drive_levels) ----------------------------
    @property
    def now(self) -> int:
        """The HAT's clock in ms (``@time``)."""
        return int(float(self._need_control().request("@time")))

    def drive_events_since(self, t: int) -> List[Dict[str, Any]]:
        return self._need_control().drive_events_since(t)

    def device_frames_since(self, t: int) -> List[Dict[str, Any]]:
        return self._need_control().device_frames_since(t)

    def _need_control(self) -> EmulatorControl:
        if self.control is None:
            raise TargetError("the emulator's control channel is not connected (open the target first)")
        return self.control

    def diagnose(self, problem: str) -> str:
        err = self.stderr_text(5)
        return f"The emulator's stderr: {err}" if err else ""


def _device_option(value: str, url: str) -> tuple[int, Optional[tuple]]:
    port, sep, spec = value.partition("=")
    if not sep or not port.strip().isdigit() or not 0 <= int(port) <= 3:
        raise TargetError(f"{url}: device takes P=SPEC with P in 0..3, e.g. device=1=0x30 or "
                          f"device=2=passive+8, got {value!r}")
    spec = spec.strip()
    if spec.lower().startswith("passive") and spec[7:8].isdigit():
        spec = "passive " + spec[7:]
    try:
        return int(port), parse_device_spec(spec)
    except (ValueError, KeyError) as exc:
        raise TargetError(f"{url}: device {value!r}: {exc.args[0] if exc.args else exc}") from None


def from_url(url: str, **options) -> EmulatorTarget:
    """``emulator``, ``emulator:R5``, ``emulator:latest?speed=10&device=0=0x30``.

    Options (keywords) override the URL: ``firmware``, ``speed``, ``devices`` ({port: spec},
    e.g. a script's layout), ``bootloader``, ``booted`` (start powered up, devices established),
    ``seed``, ``version_string``, ``baud``, ``hang_after`` (fault injection: the firmware hangs
    after the host's Nth line until a reset), ``fast_setup`` (devices set up faster than a HAT's
    2400 baud), ``extra_args``, ``command``, ``startup_timeout``.
    """
    rest = url[len("emulator"):]
    if rest and not rest.startswith(":") and not rest.startswith("?"):
        raise TargetError(f"unknown target {url!r}: did you mean emulator:{rest.lstrip(':')}?")
    parts = urlsplit("x:" + rest.lstrip(":"))
    kwargs: dict = {}
    if parts.path:
        kwargs["firmware"] = parts.path
    devices: Dict[int, Optional[tuple]] = {}
    for key, vals in parse_qs(parts.query, keep_blank_values=True).items():
        if key == "speed":
            try:
                kwargs["speed"] = float(vals[-1])
            except ValueError:
                raise TargetError(f"{url}: speed must be a number, got {vals[-1]!r}") from None
            if kwargs["speed"] <= 0:
                raise TargetError(f"{url}: speed must be positive")
        elif key == "device":
            for v in vals:
                p, spec = _device_option(v, url)
                devices[p] = spec
        elif key in ("seed", "baud", "hang_after"):
            try:
                kwargs[key] = int(vals[-1])
            except ValueError:
                raise TargetError(f"{url}: {key} must be an integer, got {vals[-1]!r}") from None
        elif key in ("bootloader", "booted", "fast_setup"):
            kwargs[key] = vals[-1] not in ("0", "false", "no")
        else:
            raise TargetError(f"{url}: unknown option {key!r} "
                              "(known: speed, device, seed, baud, bootloader, booted, hang_after, "
                              "fast_setup)")
    if devices:
        kwargs["devices"] = devices
    if "devices" in options and options["devices"] is not None:
        merged = dict(kwargs.get("devices", {}))
        merged.update(options.pop("devices"))
        options["devices"] = merged
    kwargs.update({k: v for k, v in options.items() if v is not None})
    return EmulatorTarget(url, **kwargs)
