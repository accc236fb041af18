"""Any pyserial URL: ``socket://host:port`` (a HAT on another machine behind ser2net),
``rfc2217://host:port``, ``loop://`` (a loopback, for tests), ``spy://``, ``hwgrep://``...

The port is made by ``serial.serial_for_url`` with the HAT's settings (115200 8N1).
"""
from __future__ import annotations

import errno
from urllib.parse import urlsplit

import serial

from .base import TargetError
from .pyserial_base import BAUD, PyserialTarget, SerialPort

__all__ = ["PyserialUrlTarget", "from_url", "SCHEMES"]

# The URL handlers pyserial 3.5 ships (serial/urlhandler/protocol_*.py).
SCHEMES = ("socket", "rfc2217", "loop", "spy", "hwgrep", "alt", "cp2110")


class PyserialUrlTarget(PyserialTarget):
    def _make_port(self) -> SerialPort:
        settings = self.port_settings()
        settings["baudrate"] = self.baudrate
        if self.url.lower().startswith("rfc2217:"):
            # pyserial's RFC 2217 client refuses any write_timeout (NotImplementedError at open);
            # its writes go to a TCP socket, which a stalled HAT does not block for long anyway.
            settings.pop("write_timeout", None)
        return serial.serial_for_url(self.url, do_not_open=True, **settings)

    def _explain(self, exc: BaseException) -> str:
        text = str(exc)
        parts = urlsplit(self.url)
        where = parts.netloc or self.url
        if getattr(exc, "errno", None) == errno.ECONNREFUSED or "Connection refused" in text \
                or "[Errno 111]" in text:
            return (f"connection refused by {where}: nothing is listening there. Is ser2net (or the "
                    f"emulator's --tcp mode) running on that machine, and is the port number right? ({text})")
        if "timed out" in text or "No route to host" in text or "Name or service not known" in text:
            return f"cannot reach {where}: {text}. Check the host name and the network."
        if "protocol" in text and "not known" in text:
            return (f"{self.url}: {text}. Known pyserial URL schemes: "
                    + ", ".join(s + "://" for s in SCHEMES))
        return f"cannot open {self.url}: {text}"

    def _lost(self, exc: BaseException) -> str:
        return f"the connection to {self.url} was lost: {exc}"

    def diagnose(self, problem: str) -> str:
        if problem == "silent":
            return ("The connection is up but nothing answers: is the HAT behind it powered and on the "
                    "right serial port of the remote machine, and is that port's baud rate 115200 8N1?")
        if problem == "garbage":
            return ("Check the remote end's serial settings (ser2net: 115200 8DATABITS NONE 1STOPBIT) and, "
                    "for rfc2217, that the server honours baud changes.")
        return ""


def from_url(url: str, **options) -> PyserialUrlTarget:
    baud = options.pop("baud", BAUD)
    if options:
        raise TargetError(f"{url}: options not understood here: {', '.join(sorted(options))}")
    return PyserialUrlTarget(url, baudrate=int(baud))
