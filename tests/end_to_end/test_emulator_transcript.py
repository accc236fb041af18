"""``buildhat-emulator --transcript FILE`` in every mode (pty, tcp, stdio, script): every byte both ways in
the project's JSONL transcript format (shared/formats, read back with harness/transcript.py), host-lint
findings as notes. Real child processes, a real pty and a real socket;
--booted, so no test waits for a start-up.

The host sends ``version`` and then ``bias 0.3``: R7 has no ``bias`` (FIRMWARE-FACTS §11), so it answers
``Error`` and the lint must note a not_in_profile finding.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from typing import List

import pytest
import serial

from buildhat_conformance.harness.transcript import read_transcript

CLI = [sys.executable, "-m", "buildhat_conformance.emulator.cli"]
EMPTY = ["--device", "0=none", "--device", "1=none", "--device", "2=none", "--device", "3=none"]
VERSION_R7 = b"Firmware version: 1737564117 2025-01-22T16:41:57+00:00\r\n"
HOST = [b"version\r", b"bias 0.3\r"]

pytestmark = pytest.mark.timeout(60)


def start(mode: List[str], transcript: str, **kw) -> subprocess.Popen:
    return subprocess.Popen(CLI + mode + ["--firmware", "1737564117", "--booted", "--transcript", transcript]
                            + EMPTY, stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    proc.wait(20)


def converse(read, write) -> bytes:
    """Send the two host lines, each after the previous answer; returns what the HAT sent."""
    got = b""
    for line, want in zip(HOST, (VERSION_R7, b"Error\r\n")):
        write(line)
        deadline = time.monotonic() + 20
        while want not in got and time.monotonic() < deadline:
            got += read()
        assert want in got, got
    return got


def check(path: str, got: bytes) -> None:
    t = read_transcript(path)
    assert t.meta["firmware"].startswith("1737564117")
    assert t.host_bytes == b"".join(HOST)                 # every host byte, exactly
    assert got in t.hat_bytes                             # every byte the host read, in order
    notes = [e["text"] for e in t.events if e["dir"] == "note"]
    assert any("host lint" in n and "not_in_profile" in n and "'bias 0.3'" in n for n in notes), notes
    assert t.events[-1]["dir"] == "end"
    times = [e["t"] for e in t.events]
    assert times == sorted(times)


def test_pty(tmp_path) -> None:
    path = str(tmp_path / "pty.jsonl")
    proc = start(["--pty"], path)
    try:
        pty = proc.stdout.readline().decode().strip()
        with serial.Serial(pty, 115200, timeout=0.1) as port:
            got = converse(lambda: port.read(4096), port.write)
    finally:
        stop(proc)
    check(path, got)


def test_tcp(tmp_path) -> None:
    path = str(tmp_path / "tcp.jsonl")
    proc = start(["--tcp", "127.0.0.1:0"], path)
    try:
        host, _, port = proc.stdout.readline().decode().strip().rpartition(":")
        with socket.create_connection((host, int(port)), timeout=20) as sock:
            sock.settimeout(0.1)

            def read() -> bytes:
                try:
                    return sock.recv(4096)
                except socket.timeout:
                    return b""
            got = converse(read, sock.sendall)
    finally:
        stop(proc)
    check(path, got)


def test_stdio(tmp_path) -> None:
    path = str(tmp_path / "stdio.jsonl")
    proc = start(["--stdio"], path, stdin=subprocess.PIPE)
    try:
        os.set_blocking(proc.stdout.fileno(), False)

        def read() -> bytes:
            time.sleep(0.01)
            return proc.stdout.read() or b""

        def write(data: bytes) -> None:
            proc.stdin.write(data)
            proc.stdin.flush()
        got = converse(read, write)
        proc.stdin.close()                        # EOF ends a stdio run
        assert proc.wait(20) == 0
    finally:
        stop(proc)
    check(path, got)


def test_script(tmp_path) -> None:
    script = tmp_path / "s.script"
    script.write_text("@device 0 none\n> version\n@wait 20\n> bias 0.3\n@wait 20\n")
    path = str(tmp_path / "script.jsonl")
    run = subprocess.run(CLI + ["--script", str(script), "--transcript", path], capture_output=True,
                         timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout == b""                       # the transcript went to the file instead
    t = read_transcript(path)
    assert t.host_bytes == b"".join(HOST)
    assert VERSION_R7 in t.hat_bytes and b"Error\r\n" in t.hat_bytes
    notes = [e["text"] for e in t.events if e["dir"] == "note"]
    assert any("not_in_profile" in n and "'bias 0.3'" in n for n in notes), notes
