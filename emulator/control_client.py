"""A client of the emulator's control channel (emulator/control.py). Standard library only, so that it
also runs inside a host library's own environment (the gpiozero pin factory, the pytest fixture).

    client = ControlClient.from_environment()       # BUILDHAT_EMULATOR_CONTROL (+ _TOKEN on TCP)
    client.request("@plug 1 0x30")                   # -> "ok"

Addresses as the emulator takes them: a Unix socket path, or ``tcp:HOST:PORT``.
"""
from __future__ import annotations

import os
import socket
import time
from typing import Optional

__all__ = ["ControlClient", "ControlError", "ENV_ADDRESS", "ENV_TOKEN"]

# The same names as emulator/control.py (not imported from there: that module needs the emulator).
ENV_ADDRESS = "BUILDHAT_EMULATOR_CONTROL"
ENV_TOKEN = "BUILDHAT_EMULATOR_TOKEN"


class ControlError(RuntimeError):
    """The channel cannot be reached, closed, or refused a request (the message says which)."""


class ControlClient:
    """One connection to the control channel; :meth:`request` sends a line and returns the reply line."""

    def __init__(self, address: str, token: Optional[str] = None, timeout: float = 10.0):
        self.address = address
        self.token = token
        self.timeout = timeout
        self._sock: Optional[socket.socket] = None
        self._buf = b""

    @classmethod
    def from_environment(cls, timeout: float = 10.0) -> ControlClient:
        address = os.environ.get(ENV_ADDRESS)
        if not address:
            raise ControlError(f"{ENV_ADDRESS} is not set: start buildhat-emulator with --control and export "
                               "what it prints (the pytest fixture sets it for its tests)")
        return cls(address, os.environ.get(ENV_TOKEN) or None, timeout)

    def connect(self, wait: float = 0.0) -> None:
        """Connect (retrying for ``wait`` seconds while the emulator is still starting) and authenticate."""
        deadline = time.monotonic() + wait
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
        """One request; returns the reply line as sent (``ok ...`` or ``error ...``)."""
        if self._sock is None:
            self.connect()
        assert self._sock is not None
        try:
            self._sock.sendall(line.strip().encode("utf-8") + b"\n")
            while b"\n" not in self._buf:
                chunk = self._sock.recv(65536)
                if not chunk:
                    raise ControlError(f"the emulator closed its control channel (request {line.strip()!r})")
                self._buf += chunk
        except OSError as exc:
            self.close()
            raise ControlError(f"control request {line.strip()!r} failed: {exc}") from None
        reply, _, self._buf = self._buf.partition(b"\n")
        return reply.decode("utf-8", "replace")

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        self._buf = b""

    def __enter__(self) -> ControlClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
