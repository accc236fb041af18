"""The out-of-band control channel of ``buildhat-emulator`` (docs/DEVELOPING.md).

Address: a Unix socket path, or ``tcp:HOST:PORT`` (``tcp:PORT`` means 127.0.0.1). One request
per line, one reply per line:

- world actions exactly as in a scenario script: ``@plug 1 0x30``, ``@unplug 1``,
  ``@data 0 1 05``, ``@motorfault 1 0``, ``@portfault 1``, ``@button 2 1``, ``@adc 2000``,
  ``@rate 0 10``, ``@hold 0 1``, ``@pos 0 90``  -> ``ok``
- ``@reset`` / ``@reset bootloader``  -> ``ok``
- ``@hang`` -> ``ok``: the firmware hangs until a reset (fault injection, emulator/hang.py)
- ``@time`` -> ``ok <virtual ms>``; ``@firmware`` -> ``ok <version string>`` (or ``ok bootloader``,
  ``ok hung``, ``ok reset``)
- ``@speed`` -> ``ok <speed>``; ``@speed N`` sets it (real-time runners only)
- ``@lint`` -> ``ok <JSON summary of the host-traffic lint>``
- ``@settled`` -> ``ok 1`` once the start-up is done and the layout's devices are up, else ``ok 0``
- ``@drive_events SINCE`` -> ``ok <JSON list>``: the motor-drive changes (``pwm``/``led`` events, in HAT
  ms) after HAT ms SINCE, each port's level at SINCE first (serving/drive_log.py; recent ones only)
- ``@device_frames SINCE`` -> ``ok <JSON list>``: the frames the devices received (``dev`` events) from HAT
  ms SINCE on (recent ones only)
- ``@gpio PIN LEVEL`` -> ``ok``: the HAT's RESET (GPIO 4) / BOOT0 (GPIO 22) lines as the host's GPIO drives
  them (serving/reset_pins.py; the gpiozero pin factory of emulator/host_fixtures/gpiozero_pins.py sends
  these)
- ``@auth TOKEN`` -> ``ok``: required first on TCP (the per-run token printed at start as
  ``BUILDHAT_EMULATOR_TOKEN=...``); accepted on a Unix socket, which is mode 0600 instead
- anything else, or a failure -> ``error <message>``

The server is non-blocking and driven by the runner's select loop, so requests are handled
between two emulator ticks and never race with them.
"""
from __future__ import annotations

import ipaddress
import json
import os
import secrets
import socket
import stat
from typing import Any, Callable, Dict, List, Optional, Tuple

from .drive_log import DriveLog, FrameLog
from .hat_model import WorldError
from .reset_pins import ResetPins

__all__ = ["ControlServer", "ControlHandler", "parse_control_address", "is_loopback", "MAX_REQUEST",
           "MAX_BACKLOG", "ENV_ADDRESS", "ENV_TOKEN"]

MAX_REQUEST = 4096   # a longer request line is answered with an error and dropped
# Unsent replies kept for one client; beyond this it is not reading them and is dropped. Generous: a
# ``@lint`` reply is a few KB and a client may pipeline requests.
MAX_BACKLOG = 256 * 1024
# Where clients (the pytest fixture, the gpiozero pin factory) find the channel and its token.
ENV_ADDRESS = "BUILDHAT_EMULATOR_CONTROL"
ENV_TOKEN = "BUILDHAT_EMULATOR_TOKEN"


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
        self.pins = ResetPins(emulator)
        # What the in-process targets read from their own event list: a served HAT keeps it here.
        self.drives = DriveLog()
        self.frames = FrameLog()
        on_event = getattr(emulator, "on_event", None)
        if on_event is not None:
            on_event(self.drives.record)
            on_event(self.frames.record)

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
        if head == "@drive_events":
            if len(words) != 2 or not words[1].lstrip("-").isdigit():
                raise ValueError("@drive_events takes the HAT ms since when (e.g. @drive_events 0)")
            return "ok " + json.dumps(self.drives.since(int(words[1])), separators=(",", ":"))
        if head == "@device_frames":
            if len(words) != 2 or not words[1].lstrip("-").isdigit():
                raise ValueError("@device_frames takes the HAT ms since when (e.g. @device_frames 0)")
            return "ok " + json.dumps(self.frames.since(int(words[1])), separators=(",", ":"))
        if head == "@gpio":
            return self.pins.request(words[1:])
        reply = self.emulator.world(line)
        if self.lint is not None:
            self.lint.follow(self.emulator)       # a reset replaced the Hat
        return reply


class _Client:
    """One connected control client: its unread request bytes and unsent replies."""

    def __init__(self, sock: socket.socket, authenticated: bool):
        self.sock = sock
        self.inbox = bytearray()
        self.outbox = bytearray()
        self.authenticated = authenticated


class ControlServer:
    """Listening socket plus its clients, driven by the runner's select loop: :meth:`sockets` and
    :meth:`writables` say what to watch, :meth:`handle` and :meth:`flush` act on what select() found.

    Nothing here ever blocks: a reply that the client does not read waits in its outbox, and a client
    whose outbox passes ``MAX_BACKLOG`` is dropped, so a stuck client never stalls the serial side.
    TCP is loopback only unless ``allow_remote``, and a TCP client must first send ``@auth TOKEN``
    (the per-run ``token``). A Unix socket is created mode 0600 whatever the umask.
    """

    def __init__(self, address: str, handler: Callable[[str], str], token: Optional[str] = None,
                 allow_remote: bool = False):
        self.kind, where = parse_control_address(address)
        self.handler = handler
        self.path: Optional[str] = None
        self.token: Optional[str] = None
        if self.kind == "unix":
            self.path = where
            _remove_stale_socket(where)
            self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.token = token           # optional on a Unix socket: the file mode guards it
        else:
            host = where[0]
            if not allow_remote and not is_loopback(host):
                raise ValueError(f"control address {address!r} is not a loopback address; the control "
                                 "channel changes the emulated world, so it serves other machines only "
                                 "with --allow-remote")
            self.token = token or secrets.token_hex(16)
            family = socket.AF_INET6 if ":" in host else socket.AF_INET
            self.listener = socket.socket(family, socket.SOCK_STREAM)
            self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.listener.bind(where)
            if self.path is not None:
                # Before listen() nobody can connect, so the mode is set before the socket is usable.
                os.chmod(self.path, 0o600)
        except OSError as exc:
            self.listener.close()
            raise ValueError(f"cannot listen on control address {address!r}: {exc.strerror}") from None
        self.listener.listen(8)
        self.listener.setblocking(False)
        self.clients: Dict[socket.socket, _Client] = {}

    @property
    def address(self) -> str:
        if self.kind == "unix":
            return str(self.path)
        host, port = self.listener.getsockname()[:2]
        return f"tcp:{host}:{port}"

    def environment(self) -> str:
        """The ``NAME=value`` words a client needs (printed at start; the fixture and gpiozero read them)."""
        words = [f"{ENV_ADDRESS}={self.address}"]
        if self.token is not None and self.kind == "tcp":
            words.append(f"{ENV_TOKEN}={self.token}")
        return " ".join(words)

    def sockets(self) -> List[socket.socket]:
        return [self.listener] + list(self.clients)

    def writables(self) -> List[socket.socket]:
        return [c.sock for c in self.clients.values() if c.outbox]

    def handle(self, readable: List[Any]) -> None:
        for sock in readable:
            if sock is self.listener:
                self._accept()
            elif sock in self.clients:
                self._serve(self.clients[sock])

    def flush(self, writable: List[Any]) -> None:
        for sock in writable:
            client = self.clients.get(sock)
            if client is not None:
                self._send(client)

    def _accept(self) -> None:
        try:
            sock, _ = self.listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return
        sock.setblocking(False)
        self.clients[sock] = _Client(sock, authenticated=self.kind == "unix")

    def _serve(self, client: _Client) -> None:
        try:
            data = client.sock.recv(4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._drop(client)
            return
        client.inbox += data
        while b"\n" in client.inbox and client.sock in self.clients:
            raw, _, rest = bytes(client.inbox).partition(b"\n")
            client.inbox[:] = rest
            self._reply(client, self._answer(client, raw.decode("utf-8", "replace")))
        if len(client.inbox) > MAX_REQUEST and client.sock in self.clients:
            client.inbox.clear()
            self._reply(client, "error request line too long")

    def _answer(self, client: _Client, line: str) -> str:
        words = line.split()
        if words[:1] == ["@auth"]:
            if self.token is None:
                client.authenticated = True
                return "ok"
            if len(words) == 2 and secrets.compare_digest(words[1].encode(), self.token.encode()):
                client.authenticated = True
                return "ok"
            client.authenticated = False
            return "error @auth: wrong token"
        if not client.authenticated:
            return ("error not authenticated: send @auth TOKEN first (the token the emulator printed "
                    f"as {ENV_TOKEN})")
        return self.handler(line)

    def _reply(self, client: _Client, reply: str) -> None:
        client.outbox += reply.encode("utf-8") + b"\n"
        self._send(client)
        if client.sock in self.clients and len(client.outbox) > MAX_BACKLOG:
            self._drop(client)           # it does not read its replies: stop serving it

    def _send(self, client: _Client) -> None:
        try:
            n = client.sock.send(client.outbox)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._drop(client)
            return
        del client.outbox[:n]

    def _drop(self, client: _Client) -> None:
        self.clients.pop(client.sock, None)
        client.sock.close()

    def close(self) -> None:
        for client in list(self.clients.values()):
            self._drop(client)
        self.listener.close()
        if self.path is not None:
            _remove_stale_socket(self.path)


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and any loopback IP (127.0.0.0/8, ::1); false for 0.0.0.0 and the rest."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _remove_stale_socket(path: str) -> None:
    """Remove a leftover Unix socket file; refuse to delete anything else."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISSOCK(mode):
        raise ValueError(f"control path {path!r} exists and is not a socket")
    os.unlink(path)
