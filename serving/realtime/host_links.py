"""Byte links between a host and the emulator in real time: a pty, a TCP socket, stdio.

Each link offers ``readables()`` (what select() should watch), ``on_readable(obj, limit) -> bytes``
(at most ``limit`` host bytes; raises EOFError when the host side is gone for good), ``send(data)`` (buffered,
never blocks), ``wants_write()`` / ``writables()`` / ``flush()``, and ``close()``.

Output that cannot be delivered (no TCP client; a pty nobody reads) is kept up to
``OUT_LIMIT`` bytes and then the oldest is dropped, as bytes are lost on a wire nobody listens to.
The limit is small on purpose: a host that opens the pty late should not get minutes of stale
output (the kernel's own pty buffer holds about 20 KB more).

Back-pressure (``--baud``): the runner reads no more host bytes than the wire carries, so what the
host sends faster waits in the link itself: the pty's kernel buffers (13-20 KB on Linux) and then the
host's write() blocks; on TCP the receive buffer is made small (``PACED_RCVBUF``) so the window closes.
Nothing on the master's side shrinks what a pty holds (tcflow(TCOOFF) gating was tried: each release lets
the writer fill it all at once), so a host's write() returns up to that much before the wire has carried
it, where a UART's is early by its 4 KB transmit buffer (docs/HOST-LIBRARIES.md, measured figures).
"""
from __future__ import annotations

import errno
import os
import socket
import sys
import termios
import tty
from typing import Any, List, Optional

from ...plumbing.raw_pty import open_raw_pty

__all__ = ["PtyLink", "TcpLink", "StdioLink", "OUT_LIMIT", "PACED_RCVBUF", "parse_tcp_address"]

OUT_LIMIT = 64 * 1024
_READ = 65536
# SO_RCVBUF for a paced TCP link (the kernel doubles it and keeps a floor of about 2 KB).
PACED_RCVBUF = 4096


class _Buffered:
    """Non-blocking writer with a bounded backlog."""

    out_fd: Optional[int] = None

    def __init__(self) -> None:
        self._out = bytearray()

    def send(self, data: bytes) -> None:
        self._out += data
        excess = len(self._out) - OUT_LIMIT
        if excess > 0:
            del self._out[:excess]
        self.flush()

    def wants_write(self) -> bool:
        return bool(self._out) and self.out_fd is not None

    def writables(self) -> List[Any]:
        return [self.out_fd] if self.wants_write() else []

    def flush(self) -> None:
        while self._out and self.out_fd is not None:
            try:
                n = os.write(self.out_fd, self._out)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                if exc.errno in (errno.EIO, errno.EPIPE):
                    self._out.clear()      # nobody at the other end: the bytes are lost
                    return
                raise
            del self._out[:n]


class PtyLink(_Buffered):
    """A pseudo-terminal in raw mode; the host opens :attr:`path` like a serial port."""

    def __init__(self, link: Optional[str] = None):
        super().__init__()
        try:
            self.master, self._slave, self.path = open_raw_pty(link)
        except ValueError as exc:
            raise ValueError(f"--link {exc}") from None
        os.set_blocking(self.master, False)
        self.out_fd = self.master
        self.link = link

    def readables(self, data: bool = True) -> List[Any]:
        """What select() should watch; ``data=False``: not the host's bytes (the wire is full)."""
        return [self.master] if data else []

    def on_readable(self, obj: Any, limit: int = _READ) -> bytes:
        try:
            return os.read(self.master, max(1, min(limit, _READ)))
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:     # cannot happen while we hold the slave open
                return b""
            raise

    def close(self) -> None:
        if self.link and os.path.islink(self.link) and os.readlink(self.link) == self.path:
            os.unlink(self.link)
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass


def parse_tcp_address(text: str) -> tuple[str, int]:
    """``[HOST:]PORT`` -> (host, port); the host defaults to 127.0.0.1."""
    host, _, port = text.rpartition(":")
    if not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"--tcp {text!r}: expected [HOST:]PORT with PORT 0..65535")
    return host or "127.0.0.1", int(port)


class TcpLink(_Buffered):
    """A TCP server; one host at a time (a new connection replaces the old one)."""

    def __init__(self, address: str, paced: bool = False):
        super().__init__()
        host, port = parse_tcp_address(address)
        self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if paced:   # set before listen(): an accepted socket inherits it and the window stays small
            self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, PACED_RCVBUF)
        try:
            self.listener.bind((host, port))
        except OSError as exc:
            self.listener.close()
            raise ValueError(f"cannot listen on {host}:{port}: {exc.strerror}") from None
        self.listener.listen(1)
        self.listener.setblocking(False)
        self.client: Optional[socket.socket] = None
        bound = self.listener.getsockname()
        self.address = f"{bound[0]}:{bound[1]}"

    def readables(self, data: bool = True) -> List[Any]:
        return [self.listener] + ([self.client] if self.client and data else [])

    def on_readable(self, obj: Any, limit: int = _READ) -> bytes:
        if obj is self.listener:
            try:
                conn, _ = self.listener.accept()
            except (BlockingIOError, InterruptedError):
                return b""
            self._drop_client()
            conn.setblocking(False)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.client = conn
            self.out_fd = conn.fileno()
            self._out.clear()            # output sent while nobody listened is gone
            return b""
        try:
            data = self.client.recv(max(1, min(limit, _READ))) if self.client else b""
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            data = b""
        if not data:
            self._drop_client()
        return data

    def send(self, data: bytes) -> None:
        if self.client is not None:
            super().send(data)

    def _drop_client(self) -> None:
        if self.client is not None:
            self.client.close()
        self.client = None
        self.out_fd = None
        self._out.clear()

    def close(self) -> None:
        self._drop_client()
        self.listener.close()


class StdioLink(_Buffered):
    """stdin/stdout; a terminal is put in raw mode (and restored on close)."""

    def __init__(self) -> None:
        super().__init__()
        self.in_fd, self.stdout_fd = sys.stdin.fileno(), sys.stdout.fileno()
        self.out_fd = self.stdout_fd
        self._saved = None
        if os.isatty(self.in_fd):
            self._saved = termios.tcgetattr(self.in_fd)
            tty.setraw(self.in_fd, termios.TCSANOW)
        os.set_blocking(self.stdout_fd, False)

    def readables(self, data: bool = True) -> List[Any]:
        return [self.in_fd] if data else []

    def on_readable(self, obj: Any, limit: int = _READ) -> bytes:
        try:
            data = os.read(self.in_fd, max(1, min(limit, _READ)))
        except (BlockingIOError, InterruptedError):
            return b""
        if not data:
            raise EOFError("stdin closed")
        return data

    def close(self) -> None:
        try:
            os.set_blocking(self.stdout_fd, True)
            while self._out:
                n = os.write(self.stdout_fd, self._out)
                del self._out[:n]
        except OSError:
            pass
        if self._saved is not None:
            termios.tcsetattr(self.in_fd, termios.TCSADRAIN, self._saved)
