"""The one client of the emulator's control channel (serving/control_channel.py). Standard library only, so
that
it also runs inside a host library's own environment (the gpiozero pin factory, the pytest fixture); the
``emulator:`` target wraps it as a harness Control (emulator/targets/pty_process.py).

    client = ControlClient.from_environment()       # BUILDHAT_EMULATOR_CONTROL (+ _TOKEN on TCP)
    client.request("@plug 1 0x30")                   # -> "ok" (the reply line as sent)
    client.value("@time")                            # -> "1234" (after ``ok``; ``error`` raises)
    client.drive_events_since(0)                     # -> [{"kind": "pwm", ...}, ...]

Addresses as the emulator takes them: a Unix socket path, or ``tcp:HOST:PORT``.
"""
from __future__ import annotations

import json
import os
import socket
import threading
import time
from typing import Any, Dict, List, Optional

__all__ = ["ControlClient", "ControlError", "ControlRefused", "ENV_ADDRESS", "ENV_TOKEN"]

# The same names as serving/control_channel.py (not imported from there: that module needs the emulator).
ENV_ADDRESS = "BUILDHAT_EMULATOR_CONTROL"
ENV_TOKEN = "BUILDHAT_EMULATOR_TOKEN"


class ControlError(RuntimeError):
    """The channel cannot be reached, closed, or refused a request (the message says which)."""


class ControlRefused(ControlError):
    """The emulator answered a request with ``error <message>`` (the channel itself is fine)."""


class ControlClient:
    """One connection to the control channel; :meth:`request` sends a line and returns the reply line.
    Thread-safe: a request and its reply are one step, so two threads never read each other's reply."""

    def __init__(self, address: str, token: Optional[str] = None, timeout: float = 10.0):
        self.address = address
        self.token = token
        self.timeout = timeout
        self._sock: Optional[socket.socket] = None
        self._buf = b""
        self._lock = threading.RLock()    # re-entered by connect()'s @auth

    @classmethod
    def from_environment(cls, timeout: float = 10.0) -> ControlClient:
        address = os.environ.get(ENV_ADDRESS)
        if not address:
            raise ControlError(f"{ENV_ADDRESS} is not set: start buildhat-emulator with --control and export "
                               "what it prints (the pytest fixture sets it for its tests)")
        return cls(address, os.environ.get(ENV_TOKEN) or None, timeout)

    @property
    def connected(self) -> bool:
        return self._sock is not None

    def connect(self, wait: float = 0.0) -> None:
        """Connect (retrying for ``wait`` seconds while the emulator is still starting) and authenticate."""
        deadline = time.monotonic() + wait
        with self._lock:
            while True:
                try:
                    self._sock = self._open()
                    break
                except OSError as exc:
                    if time.monotonic() >= deadline:
                        raise ControlError(f"cannot reach the emulator's control channel {self.address}: "
                                           f"{exc.strerror or exc}") from None
                    time.sleep(0.02)
            if self.token:
                reply = self.request(f"@auth {self.token}")
                if reply != "ok":
                    self.close()
                    raise ControlError(f"the emulator refused the token for {self.address}: {reply}")

    def _open(self) -> socket.socket:
        if self.address.startswith("tcp:"):
            host, _, port = self.address[4:].rpartition(":")
            sock = socket.create_connection((host or "127.0.0.1", int(port)), timeout=self.timeout)
        else:
            sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            sock.settimeout(self.timeout)
            try:
                sock.connect(self.address)
            except OSError:
                sock.close()
                raise
        return sock

    def request(self, line: str) -> str:
        """One request; returns the reply line as sent (``ok ...`` or ``error ...``). Connects first if
        not connected; a lost channel or a reply later than ``timeout`` raises ControlError."""
        line = line.strip()
        if "\n" in line:
            raise ValueError(f"a control request is one line, got {line!r}")
        with self._lock:
            if self._sock is None:
                self.connect()
            assert self._sock is not None
            try:
                self._sock.sendall(line.encode("utf-8") + b"\n")
                while b"\n" not in self._buf:
                    chunk = self._sock.recv(65536)
                    if not chunk:
                        self.close()
                        raise ControlError(f"the emulator closed its control channel (request {line!r})")
                    self._buf += chunk
            except socket.timeout:
                self.close()      # a late reply would answer the next request
                raise ControlError(f"the emulator did not answer control request {line!r} within "
                                   f"{self.timeout:g} s") from None
            except OSError as exc:
                self.close()
                raise ControlError(f"control request {line!r} failed: {exc}") from None
            reply, _, self._buf = self._buf.partition(b"\n")
        return reply.decode("utf-8", "replace").rstrip("\r")

    def value(self, line: str) -> str:
        """One request whose reply must be ``ok [value]``; returns the value ("" for a bare ``ok``).
        ``error <message>`` raises ControlRefused, anything else ControlError, each naming the request."""
        reply = self.request(line)
        if reply == "ok" or reply.startswith("ok "):
            return reply[3:]
        if reply.startswith("error"):
            raise ControlRefused(f"the emulator refused {line.strip()!r}: {reply[5:].strip()}")
        raise ControlError(f"the emulator sent an unexpected control reply to {line.strip()!r}: {reply!r}")

    def drive_events_since(self, t: int) -> List[Dict[str, Any]]:
        """``@drive_events t``: the motor-drive changes after HAT ms ``t``, each port's level at ``t``
        first (``pwm``/``led`` events, as the in-process targets' ``drive_events``)."""
        return self._json_list("@drive_events", t)

    def device_frames_since(self, t: int) -> List[Dict[str, Any]]:
        """``@device_frames t``: the frames the devices received from HAT ms ``t`` on (``dev`` events,
        as the in-process targets' ``device_frames``)."""
        return self._json_list("@device_frames", t)

    def _json_list(self, request: str, t: int) -> List[Dict[str, Any]]:
        reply = self.value(f"{request} {int(t)}")
        try:
            events = json.loads(reply)
        except ValueError:
            events = None
        if not isinstance(events, list):
            raise ControlError(f"the emulator sent an unreadable {request} reply: {reply[:80]!r}")
        return events

    def close(self) -> None:
        with self._lock:
            if self._sock is not None:
                try:
                    self._sock.close()
                finally:
                    self._sock = None
            self._buf = b""

    def __enter__(self) -> ControlClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
