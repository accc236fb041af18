"""The mock's transports: a fake HAT (transcripts/mock.py) served on a pseudo-terminal or a TCP
port, one host at a time, until the host goes or (``strict``) departs from the recording."""
from __future__ import annotations

import os
import select
import socket
import threading
from typing import Callable, Optional

from ..harness.transcript import Transcript
from ..plumbing.cli_options import UsageError
from ..plumbing.raw_pty import open_raw_pty
from .mock import MockHat

__all__ = ["serve_pty", "serve_tcp"]


class _Stop(Exception):
    pass


def _serve_fd(mock: MockHat, fd: int, stop: threading.Event, strict: bool) -> int:
    mock.start()
    try:
        while not stop.is_set():
            ready, _, _ = select.select([fd], [], [], 0.1)
            if not ready:
                continue
            try:
                data = os.read(fd, 4096)
            except OSError:
                return 0
            if not data:
                return 0
            if mock.feed(data) and strict:
                mock.log("--strict: stopping at the first departure")
                return 1
    finally:
        mock.close()
    return 0


def serve_pty(transcript: Transcript, link: Optional[str] = None, speed: Optional[float] = None,
              strict: bool = False, stop: Optional[threading.Event] = None,
              on_ready: Optional[Callable[[str], None]] = None,
              on_mock: Optional[Callable[[MockHat], None]] = None) -> int:
    """Serve on a new pseudo-terminal until ``stop`` is set; ``on_ready`` gets the device path."""
    master, slave, path = open_raw_pty(link)   # raw: bytes pass as on a UART (CR stays CR)
    stop = stop or threading.Event()

    def write(data: bytes) -> None:
        view = memoryview(data)
        while view:
            n = os.write(master, view)
            view = view[n:]

    mock = MockHat(transcript, write, speed=speed)
    if on_mock is not None:
        on_mock(mock)
    (on_ready or (lambda p: print(p, flush=True)))(link or path)
    try:
        # Our own slave fd stays open so a host closing and reopening the device does not end the run.
        return _serve_fd(mock, master, stop, strict)
    finally:
        mock.log(mock.summary())
        os.close(master)
        os.close(slave)
        if link and os.path.islink(link):
            os.unlink(link)


def serve_tcp(transcript: Transcript, host: str, port: int, speed: Optional[float] = None,
              strict: bool = False, once: bool = False, stop: Optional[threading.Event] = None,
              on_ready: Optional[Callable[[str], None]] = None) -> int:
    """Serve one client at a time; every connection starts from the recording's start-up."""
    stop = stop or threading.Event()
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        srv.bind((host, port))
    except OSError as exc:      # a port in use or not ours to take: the user's choice, one line
        srv.close()
        raise UsageError(f"--tcp {host}:{port}: {exc.strerror or exc}") from None
    srv.listen(1)
    srv.settimeout(0.2)
    (on_ready or (lambda p: print(p, flush=True)))(f"socket://{host}:{srv.getsockname()[1]}")
    status = 0
    try:
        while not stop.is_set():
            try:
                conn, _addr = srv.accept()
            except socket.timeout:
                continue
            with conn:
                mock = MockHat(transcript, conn.sendall, speed=speed)
                status = _serve_fd(mock, conn.fileno(), stop, strict)
                mock.log(mock.summary())
            if once or status:
                break
    finally:
        srv.close()
    return status
