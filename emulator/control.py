"""The out-of-band control channel of ``buildhat-emulator`` (docs/DEVELOPING.md).

Address: a Unix socket path, or ``tcp:HOST:PORT`` (``tcp:PORT`` means 127.0.0.1). One request
per line, one reply per line:

- world actions exactly as in a scenario script: ``@plug 1 0x30``, ``@unplug 1``,
  ``@data 0 1 05``, ``@motorfault 1 0``, ``@portfault 1``, ``@button 2 1``, ``@adc 2000``,
  ``@rate 0 10``, ``@hold 0 1``, ``@pos 0 90``  -> ``ok``
- ``@reset`` / ``@reset bootloader``  -> ``ok``
- ``@time`` -> ``ok <virtual ms>``; ``@firmware`` -> ``ok <version string>`` (or ``ok bootloader``)
- ``@speed`` -> ``ok <speed>``; ``@speed N`` sets it (real-time runners only)
- ``@lint`` -> ``ok <JSON summary of the host-traffic lint>``
- ``@settled`` -> ``ok 1`` once the start-up is done and the layout's devices are up, else ``ok 0``
- anything else, or a failure -> ``error <message>``

The server is non-blocking and driven by the runner's select loop, so requests are handled
between two emulator ticks and never race with them.
"""
from __future__ import annotations

import os
import socket
import stat
from typing import Any, Callable, Dict, List, Optional, Tuple

from .world import WorldError

__all__ = ["ControlServer", "ControlHandler", "parse_control_address", "MAX_REQUEST"]

MAX_REQUEST = 4096   # a longer request line is answered with an error and dropped


def parse_control_address(text: str) -> Tuple[str, Any]:
    """``tcp:HOST:PORT`` / ``tcp:PORT`` -> ("tcp", (host, port)); anything else -> ("unix", path)."""
    if text.startswith("tcp:"):
        rest = text[4:]
        host, _, port = rest.rpartition(":")
        if not port.isdigit() or not 0 <= int(port) <= 65535:
            raise ValueError(f"control address {text!r}: expected tcp:HOST:PORT or tcp:PORT")
        return "tcp", (host or "127.0.0.1", int(port))
    if not text:
        raise ValueError("control address is empty")
    return "unix", text


class ControlHandler:
    """Turns one request line into one reply line for an :class:`~.api.Emulator`."""

    def __init__(self, emulator: Any, clock: Any = None, lint: Any = None):
        self.emulator = emulator
        self.clock = clock        # a RealTimeClock (for @speed), or None in virtual time
        self.lint = lint          # a HostLint, or None

    def __call__(self, line: str) -> str:
        try:
            return self._handle(line.strip())
        except (WorldError, ValueError, KeyError, RuntimeError) as exc:
            msg = exc.args[0] if exc.args else type(exc).__name__
            return "error " + " ".join(str(msg).split())

    def _handle(self, line: str) -> str:
        words = line.split()
        if not words:
            raise ValueError("empty request")
        head = words[0]
        if head == "@speed":
            if self.clock is None:
                raise ValueError("@speed: this runner uses virtual time")
            if len(words) == 2:
                self.clock.set_speed(float(words[1]))
            elif len(words) > 2:
                raise ValueError("@speed takes at most one number")
            return f"ok {self.clock.speed:g}"
        if head == "@lint":
            if self.lint is None:
                raise ValueError("@lint: no host lint is running")
            return "ok " + " ".join(self.lint.summary_json().split("\n"))
        if head == "@settled":
            return f"ok {int(self.emulator.settled())}"
        reply = self.emulator.world(line)
        if self.lint is not None:
            self.lint.follow(self.emulator)       # a reset replaced the Hat
        return reply


class ControlServer:
    """Listening socket plus its clients; call :meth:`handle` with what select() found readable."""

    def __init__(self, address: str, handler: Callable[[str], str]):
        self.kind, where = parse_control_address(address)
        self.handler = handler
        self.path: Optional[str] = None
        if self.kind == "unix":
            self.path = where
            _remove_stale_socket(where)
            self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        else:
            self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.listener.bind(where)
        except OSError as exc:
            self.listener.close()
            raise ValueError(f"cannot listen on control address {address!r}: {exc.strerror}") from None
        self.listener.listen(8)
        self.listener.setblocking(False)
        self.clients: Dict[socket.socket, bytearray] = {}

    @property
    def address(self) -> str:
        if self.kind == "unix":
            return str(self.path)
        host, port = self.listener.getsockname()[:2]
        return f"tcp:{host}:{port}"

    def sockets(self) -> List[socket.socket]:
        return [self.listener] + list(self.clients)

    def handle(self, readable: List[Any]) -> None:
        for sock in readable:
            if sock is self.listener:
                self._accept()
            elif sock in self.clients:
                self._serve(sock)

    def _accept(self) -> None:
        try:
            conn, _ = self.listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        conn.setblocking(True)    # replies are short; a blocking send keeps them whole
        conn.settimeout(5.0)
        self.clients[conn] = bytearray()

    def _serve(self, sock: socket.socket) -> None:
        try:
            data = sock.recv(4096)
        except (BlockingIOError, InterruptedError, socket.timeout):
            return
        except OSError:
            data = b""
        if not data:
            self._drop(sock)
            return
        buf = self.clients[sock]
        buf += data
        while b"\n" in buf:
            raw, _, rest = bytes(buf).partition(b"\n")
            buf[:] = rest
            reply = self.handler(raw.decode("utf-8", "replace"))
            try:
                sock.sendall(reply.encode("utf-8") + b"\n")
            except OSError:
                self._drop(sock)
                return
        if len(buf) > MAX_REQUEST:
            buf.clear()
            try:
                sock.sendall(b"error request line too long\n")
            except OSError:
                self._drop(sock)

    def _drop(self, sock: socket.socket) -> None:
        self.clients.pop(sock, None)
        sock.close()

    def close(self) -> None:
        for sock in list(self.clients):
            self._drop(sock)
        self.listener.close()
        if self.path is not None:
            _remove_stale_socket(self.path)


def _remove_stale_socket(path: str) -> None:
    """Remove a leftover Unix socket file; refuse to delete anything else."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISSOCK(mode):
        raise ValueError(f"control path {path!r} exists and is not a socket")
    os.unlink(path)
