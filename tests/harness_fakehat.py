"""Small real stand-ins for the harness tests: a responder that speaks a sliver of the
Build HAT protocol, run on a real pty (a thread on the master side), on stdin/stdout (a real
child process for ``cmd:``), or as a stand-in ``buildhat-emulator --pty --control``.

It is deliberately tiny and is not the emulator: it answers ``version``, ``vin``, ``echo``,
``list`` and ``Error`` for anything else, with the firmware's line editor rules for CR and
echo (FIRMWARE-FACTS §1), so that the harness can be tested before and apart from the emulator.

Run as a program:
  python harness_fakehat.py --stdio [--mode firmware|bootloader|silent|garbage]
                            [--stream N] [--wrote FILE] [--die-after N]
  python harness_fakehat.py --pty --control PATH [--firmware X] [--speed N] [--device P=SPEC]...
                            [--fail MESSAGE]
"""
from __future__ import annotations

import argparse
import io
import os
import random
import select
import socket
import sys
import threading
import time
import tty
from typing import Optional

VERSION = "1737564117 2025-01-22T16:41:57+00:00"
BOOTLOADER_VERSION = "1737564075 2025-01-22T16:41:15+00:00"


class FakeHat:
    """bytes in -> bytes out, like the command port (firmware or bootloader flavour)."""

    def __init__(self, mode: str = "firmware", version: str = VERSION, seed: int = 1):
        self.mode, self.version = mode, version
        self.echo = mode == "bootloader"
        self.line = bytearray()
        self.rng = random.Random(seed)
        self.commands = 0

    def feed(self, data: bytes) -> bytes:
        if self.mode == "silent":
            return b""
        if self.mode == "garbage":
            return bytes(self.rng.randrange(256) for _ in range(len(data) * 3 + 8))
        out = bytearray()
        for b in data:
            if b == 0x0D and bytes(self.line) == b"mute":
                self.line.clear()   # a non-conforming target: no CRLF for this line
            elif b == 0x0D:
                out += b"\r\n" + self._run(bytes(self.line))
                self.line.clear()
            else:
                self.line.append(b)
                if self.echo:
                    out.append(b)
        return bytes(out)

    def _run(self, line: bytes) -> bytes:
        self.commands += 1
        text = line.decode("latin-1").strip()
        if self.mode == "bootloader":
            if text == "version":
                body = f"BuildHAT bootloader version {BOOTLOADER_VERSION}\r\n"
            elif text == "":
                body = ""
            else:
                body = "Error\r\n"
            return (body + "BHBL> ").encode()
        if text == "version":
            body = f"Firmware version: {self.version}\r\n"
        elif text == "vin":
            body = "7.20 V\r\n"
        elif text.startswith("echo "):
            self.echo = text.split()[1] != "0"
            body = ""
        elif text == "list":
            body = "".join(f"P{p}: no device detected\r\n" for p in range(4))
        elif text == "":
            body = ""
        else:
            body = "Error\r\n"
        return (body + ("P0>" if self.echo else "")).encode()


class PtyResponder:
    """A FakeHat on the master side of a real pty; ``path`` is the slave for pyserial."""

    def __init__(self, mode: str = "firmware", version: str = VERSION):
        self.hat = FakeHat(mode, version)
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no CR/LF translation: bytes pass as they are
        self.path = os.ttyname(self.slave)
        self.received = bytearray()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                time.sleep(0.02)   # EIO while no one has the slave open
                continue
            self.received += data
            reply = self.hat.feed(data)
            if reply:
                os.write(self.master, reply)

    def send(self, data: bytes) -> None:
        """Unsolicited output, as a HAT's asynchronous lines."""
        os.write(self.master, data)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


def serve_stdio(mode: str, stream: int, wrote: Optional[str], die_after: Optional[int]) -> int:
    hat = FakeHat(mode)
    log = open(wrote, "ab", buffering=0) if wrote else None
    out = sys.stdout.buffer

    def emit(data: bytes) -> None:
        out.write(data)
        out.flush()
        if log is not None:
            log.write(data)   # after the write: the log never holds a byte that was not sent

    n = 0
    buffered = sys.stdin.buffer
    assert isinstance(buffered, io.BufferedReader)
    stdin = buffered.raw                # unbuffered: select() sees what is really waiting
    while True:
        ready, _, _ = select.select([stdin], [], [], 0.01)
        if ready:
            data = os.read(stdin.fileno(), 4096)
            if not data:
                return 0
            reply = hat.feed(data)
            if reply:
                emit(reply)
            if die_after is not None and hat.commands >= die_after:
                sys.stderr.write(f"fakehat: giving up after {hat.commands} commands\n")
                sys.stderr.flush()
                return 3
        elif stream and hat.commands >= 1:
            n += 1
            # a data line, and now and then a partial one (as a prompt would be)
            emit(f"P0M0: +{n}\r\n".encode() + (b"P0>" if n % 7 == 0 else b""))
            time.sleep(0.002)
            if n >= stream:
                stream = 0
                emit(b"P0>")  # end on output without CRLF, as a HAT with echo on would


def serve_pty_emulator(args: argparse.Namespace) -> int:
    if args.fail:
        sys.stderr.write(args.fail + "\n")
        return 2
    responder = PtyResponder()
    srv = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    srv.bind(args.control)
    srv.listen(1)
    print(responder.path, flush=True)
    speed = args.speed or 1.0

    def handle(line: str) -> str:
        word = line.split()[0] if line.split() else ""
        if word == "@speed":
            return f"ok {speed:g}"
        if word == "@firmware":
            return f"ok {VERSION}"
        if word == "@explode":
            return "error no such action"
        if word == "@plug":
            port = line.split()[1]
            responder.send(f"P{port}: connecting to active device\r\n".encode())
            return "ok"
        if word == "@devices":
            return "ok " + ";".join(args.device)
        return "ok"

    conn, _ = srv.accept()
    buf = b""
    while True:
        chunk = conn.recv(4096)
        if not chunk:
            return 0
        buf += chunk
        while b"\n" in buf:
            raw, buf = buf.split(b"\n", 1)
            conn.sendall(handle(raw.decode()).encode() + b"\n")


def main(argv: Optional[list] = None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--stdio", action="store_true")
    ap.add_argument("--mode", default="firmware")
    ap.add_argument("--stream", type=int, default=0)
    ap.add_argument("--wrote")
    ap.add_argument("--die-after", type=int)
    ap.add_argument("--pty", action="store_true")
    ap.add_argument("--control")
    ap.add_argument("--firmware", default="latest")
    ap.add_argument("--speed", type=float)
    ap.add_argument("--device", action="append", default=[])
    ap.add_argument("--fail")
    args = ap.parse_args(argv)
    if args.stdio:
        return serve_stdio(args.mode, args.stream, args.wrote, args.die_after)
    if args.pty:
        return serve_pty_emulator(args)
    ap.error("give --stdio or --pty")
    return 2


HERE = os.path.abspath(__file__)

if __name__ == "__main__":
    sys.exit(main())
