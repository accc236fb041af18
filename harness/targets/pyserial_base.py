"""The part every pyserial-backed target shares: a ``serial.Serial`` (or a URL handler's
subclass) opened at 115200 8N1 without flow control, read in short slices.

Subclasses say how to build the port (:meth:`PyserialTarget._make_port`) and how to
explain an open failure in their own terms (:meth:`PyserialTarget._explain`).
"""
from __future__ import annotations

import abc
import time
from typing import Optional, Protocol

import serial

from .base import NotReading, Target, TargetError

__all__ = ["PyserialTarget", "SerialPort", "BAUD"]

BAUD = 115200            # FIRMWARE-BEHAVIOUR.md#fb-uart: UART0 at 115200 baud, 8N1, no flow control
_SLICE = 0.05            # the port's own read timeout; read() loops slices up to its timeout


class SerialPort(Protocol):
    """What a target uses of a pyserial port: ``serial.Serial`` and the URL handlers' classes
    have it (``serial.SerialBase`` alone does not: it leaves open/in_waiting to them)."""

    @property
    def is_open(self) -> bool: ...

    @property
    def in_waiting(self) -> int: ...

    def open(self) -> None: ...

    def close(self) -> None: ...

    def read(self, size: int = 1, /) -> bytes: ...

    def write(self, data: bytes, /) -> Optional[int]: ...

    def flush(self) -> None: ...


class PyserialTarget(Target):
    """A target whose bytes go through a pyserial port object."""

    def __init__(self, url: str, baudrate: int = BAUD):
        self.url = url
        self.baudrate = int(baudrate)
        self.port: Optional[SerialPort] = None

    @abc.abstractmethod
    def _make_port(self) -> SerialPort:
        """A configured but not yet opened port."""

    def _explain(self, exc: BaseException) -> str:
        """An actionable message for an open failure (subclasses know their link)."""
        return f"cannot open {self.url}: {exc}"

    def open(self) -> None:
        if self.is_open:
            return
        try:
            port = self._make_port()
            if not port.is_open:
                port.open()
        except (serial.SerialException, OSError, ValueError) as exc:
            raise TargetError(self._explain(exc)) from exc
        self.port = port
        self.is_open = True

    def write(self, data: bytes) -> None:
        port = self._require_port()
        try:
            # The port's write_timeout is the write deadline (port_settings): pyserial raises
            # SerialTimeoutException when the bytes were not taken in time.
            port.write(data)
            port.flush()
        except serial.SerialTimeoutException:
            raise NotReading(f"{self.url} stopped reading: {len(data):,} bytes not taken in "
                             f"{self.write_deadline:g} s") from None
        except (serial.SerialException, OSError) as exc:
            raise TargetError(f"writing to {self.url} failed: {exc}") from exc

    def read(self, timeout: float) -> bytes:
        port = self._require_port()
        # The port keeps one short timeout set at open: changing it per call would
        # reconfigure the tty while the session's other thread may be writing.
        slices = max(1, int(round(timeout / _SLICE)))
        try:
            if timeout < _SLICE / 2:
                # H10: a short read (the fuzzer's look for a prompt after a fence) must not
                # cost a whole slice: poll what is waiting instead, about every millisecond.
                deadline = time.monotonic() + timeout
                while True:
                    waiting = port.in_waiting
                    if waiting:
                        return port.read(waiting)
                    if time.monotonic() >= deadline:
                        return b""
                    time.sleep(0.001)
            for _ in range(slices):
                data = port.read(1)
                if data:
                    waiting = port.in_waiting
                    return data + (port.read(waiting) if waiting else b"")
        except (serial.SerialException, OSError) as exc:
            raise TargetError(self._lost(exc)) from exc
        return b""

    def _lost(self, exc: BaseException) -> str:
        return f"{self.url} went away while reading: {exc}"

    def close(self) -> None:
        port, self.port = self.port, None
        self.is_open = False
        if port is not None:
            try:
                port.close()
            except (serial.SerialException, OSError):
                pass

    def _require_port(self) -> SerialPort:
        if self.port is None:
            raise TargetError(f"{self.url} is not open")
        return self.port

    def port_settings(self) -> dict:
        """115200 8N1, no flow control, short read timeout, the write deadline."""
        return dict(baudrate=BAUD, bytesize=serial.EIGHTBITS, parity=serial.PARITY_NONE,
                    stopbits=serial.STOPBITS_ONE, xonxoff=False, rtscts=False, dsrdtr=False,
                    timeout=_SLICE, write_timeout=self.write_deadline)
