"""The control channel's guards (serving/control_channel.py): loopback only unless --allow-remote, a per-run
token on
TCP, a Unix socket of mode 0600 whatever the umask, and a client that stops reading dropped without
stalling the serial side. Real child processes and sockets; --booted so nothing waits for a start-up.
"""
from __future__ import annotations

import os
import re
import signal
import socket
import stat
import subprocess
import sys
import time
from typing import Dict, List

import pytest
import serial

CLI = [sys.executable, "-m", "buildhat_conformance.emulator.cli"]
BOOTED = ["--firmware", "1737564117", "--booted"] + [a for p in range(4) for a in ("--device", f"{p}=none")]
VERSION_R7 = b"Firmware version: 1737564117"

pytestmark = pytest.mark.timeout(90)


def start(args: List[str], **kw) -> subprocess.Popen:
    return subprocess.Popen(CLI + args + BOOTED, stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    proc.wait(20)


def announced(proc: subprocess.Popen) -> Dict[str, str]:
    """The NAME=value words the emulator prints on stderr at start (before the link's line on stdout)."""
    line = proc.stderr.readline().decode()
    return dict(re.findall(r"(BUILDHAT_EMULATOR_\w+)=(\S+)", line))


def ask(sock: socket.socket, line: str) -> str:
    sock.sendall(line.encode() + b"\n")
    data = b""
    while not data.endswith(b"\n"):
        chunk = sock.recv(4096)
        if not chunk:
            break
        data += chunk
    return data.decode().strip()


def test_a_non_loopback_control_address_is_refused_with_one_line() -> None:
    run = subprocess.run(CLI + ["--pty", "--control", "tcp:0.0.0.0:0"] + BOOTED, capture_output=True,
                         timeout=60)
    err = run.stderr.decode().strip()
    assert run.returncode == 2 and len(err.splitlines()) == 1, err
    assert "not a loopback address" in err and "--allow-remote" in err and "Traceback" not in err


def test_allow_remote_listens_on_any_address_and_still_asks_for_the_token() -> None:
    proc = start(["--pty", "--control", "tcp:0.0.0.0:0", "--allow-remote"])
    try:
        env = announced(proc)
        port = int(env["BUILDHAT_EMULATOR_CONTROL"].rpartition(":")[2])
        with socket.create_connection(("127.0.0.1", port), timeout=20) as sock:
            assert ask(sock, "@time").startswith("error not authenticated")
            assert ask(sock, f"@auth {env['BUILDHAT_EMULATOR_TOKEN']}") == "ok"
            assert ask(sock, "@time").startswith("ok ")
    finally:
        stop(proc)


def test_tcp_control_needs_the_per_run_token() -> None:
    tokens = []
    for _ in range(2):
        proc = start(["--pty", "--control", "tcp:127.0.0.1:0"])
        try:
            env = announced(proc)
            token = env["BUILDHAT_EMULATOR_TOKEN"]
            tokens.append(token)
            host, _, port = env["BUILDHAT_EMULATOR_CONTROL"][4:].rpartition(":")
            assert host == "127.0.0.1"
            with socket.create_connection((host, int(port)), timeout=20) as sock:
                assert ask(sock, "@plug 0 0x30").startswith("error not authenticated")
                assert ask(sock, "@auth " + "0" * len(token)) == "error @auth: wrong token"
                assert ask(sock, "@firmware").startswith("error not authenticated")
                assert ask(sock, f"@auth {token}") == "ok"
                assert ask(sock, "@firmware").startswith("ok 1737564117")
        finally:
            stop(proc)
    assert tokens[0] != tokens[1] and len(tokens[0]) >= 16          # per run, not guessable


def test_unix_control_socket_is_private_whatever_the_umask(tmp_path) -> None:
    path = tmp_path / "ctl.sock"
    proc = start(["--pty", "--control", str(path)], preexec_fn=lambda: os.umask(0))
    try:
        assert announced(proc)["BUILDHAT_EMULATOR_CONTROL"] == str(path)
        mode = os.stat(path).st_mode
        assert stat.S_ISSOCK(mode) and stat.S_IMODE(mode) == 0o600, oct(mode)
    finally:
        stop(proc)


def test_a_client_that_stops_reading_is_dropped_and_the_serial_side_keeps_answering(tmp_path) -> None:
    path = tmp_path / "ctl.sock"
    proc = start(["--pty", "--control", str(path)])
    try:
        announced(proc)
        pty = proc.stdout.readline().decode().strip()
        stuck = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        stuck.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stuck.connect(str(path))
        stuck.setblocking(False)
        # Thousands of @lint requests (each reply a few hundred bytes) and never a read: far more reply
        # bytes than the socket buffers and the server's per-client backlog hold.
        flood = b"@lint\n" * 20000
        sent = 0
        deadline = time.monotonic() + 30
        dropped = False
        while sent < len(flood) and time.monotonic() < deadline:
            try:
                sent += stuck.send(flood[sent:sent + 65536])
            except BlockingIOError:
                time.sleep(0.01)
            except (BrokenPipeError, ConnectionResetError):
                dropped = True
                break
        # While that client still has not read a byte, the HAT answers on the serial side.
        with serial.Serial(pty, 115200, timeout=0.1) as port:
            for _ in range(3):
                port.write(b"version\r")
                got = b""
                until = time.monotonic() + 20
                while VERSION_R7 not in got and time.monotonic() < until:
                    got += port.read(4096)
                assert VERSION_R7 in got, got
        # The stuck client was dropped: reading now ends in EOF (or a reset), well before 20000 replies.
        stuck.setblocking(True)
        stuck.settimeout(20)
        replies = 0
        try:
            while True:
                chunk = stuck.recv(65536)
                if not chunk:
                    break
                replies += chunk.count(b"\n")
        except (ConnectionResetError, BrokenPipeError):
            pass
        stuck.close()
        assert dropped or replies < 20000, replies
        assert proc.poll() is None                    # the emulator itself carries on
    finally:
        stop(proc)
