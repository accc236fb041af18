"""A stand-in for the ``gpiod`` package (libgpiod v2 bindings) for tests, put first on PYTHONPATH.

Its chip's lines 4 and 22 are the emulator's RESET and BOOT0 pins, driven through the emulator's
control channel (``@gpio``; address in BUILDHAT_EMULATOR_CONTROL, a Unix socket), as a Raspberry
Pi's header drives a real HAT's. Only what harness/targets/gpio_reset.py calls is here, with
the real package's names and signatures.
"""
from __future__ import annotations

import os
import socket
from typing import Any, Dict, Optional

from .line import Direction, Value

__all__ = ["LineSettings", "is_gpiochip_device", "request_lines"]

_PINS = {4: "reset", 22: "boot0"}


class LineSettings:
    def __init__(self, direction: Direction = Direction.INPUT, output_value: Value = Value.INACTIVE,
                 **_other: Any):
        self.direction, self.output_value = direction, output_value


def is_gpiochip_device(path: str) -> bool:
    return os.path.exists(path)


class _Request:
    def __init__(self, sock: socket.socket):
        self._sock = sock
        self._file = sock.makefile("rb")

    def _say(self, line: str) -> None:
        self._sock.sendall(line.encode() + b"\n")
        reply = self._file.readline().decode().strip()
        if reply != "ok":
            raise OSError(f"the emulator refused {line!r}: {reply!r}")

    def set_value(self, line: int, value: Value) -> None:
        self._say(f"@gpio {_PINS[line]} {1 if value == Value.ACTIVE else 0}")

    def release(self) -> None:
        for pin in _PINS.values():
            self._say(f"@gpio {pin} z")
        self._file.close()
        self._sock.close()


def request_lines(path: str, consumer: Optional[str] = None,
                  config: Optional[Dict[int, LineSettings]] = None, **_other: Any) -> _Request:
    if not is_gpiochip_device(path):
        raise FileNotFoundError(path)
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.connect(os.environ["BUILDHAT_EMULATOR_CONTROL"])
    request = _Request(sock)
    for line, settings in (config or {}).items():
        if settings.direction == Direction.OUTPUT:
            request.set_value(line, settings.output_value)
    return request
