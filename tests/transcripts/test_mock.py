"""`mock`: a transcript served as a fake HAT over a real pty and a real TCP socket."""
from __future__ import annotations

import io
import os
import select
import socket
import subprocess
import sys
import threading
import time

import pytest

from buildhat_conformance.harness.transcript import TranscriptWriter, read_transcript
from buildhat_conformance.transcripts.mock import MockHat, exchanges_of
from buildhat_conformance.transcripts.mock_serve import serve_pty, serve_tcp

VERSION = b"Firmware version: 1737564117 2025-01-22T16:41:57+00:00"


def recording() -> str:
    """A small recording written through the project's own transcript writer."""
    buf = io.StringIO()
    w = TranscriptWriter(buf, {"firmware": "1737564117", "target": "hand-made"})
    w.hat(-300, b"\r\nType help <RETURN> for help\r\n")
    w.hat(-100, b"Done initialising ports\r\n")
    w.host(0, b"version\r")
    w.hat(1, b"\r\n" + VERSION + b"\r\n")
    w.host(50, b"vin\r")
    w.hat(51, b"\r\n7.20 V\r\n")
    w.host(100, b"echo 1\r")
    w.hat(101, b"\r\nP0>")
    w.host(150, b"p 2\r")
    w.hat(151, b"p 2\r\nP2>")
    w.end(200)
    return buf.getvalue()


def read_until(fd: int, needle: bytes, timeout: float = 5.0) -> bytes:
    got = bytearray()
    deadline = time.monotonic() + timeout
    while needle not in got and time.monotonic() < deadline:
        r, _, _ = select.select([fd], [], [], 0.05)
        if r:
            got += os.read(fd, 4096)
    return bytes(got)


def read_quiet(fd: int, quiet: float = 0.3) -> bytes:
    got = bytearray()
    while True:
        r, _, _ = select.select([fd], [], [], quiet)
        if not r:
            return bytes(got)
        got += os.read(fd, 4096)


def test_exchanges_follow_the_recording():
    ex = exchanges_of(read_transcript(io.StringIO(recording())))
    assert [e.host for e in ex] == [None, b"version\r", b"vin\r", b"echo 1\r", b"p 2\r"]
    assert b"".join(d for _t, d in ex[0].output).endswith(b"Done initialising ports\r\n")
    assert ex[2].output == [(1.0, b"\r\n"), (1.0, b"7.20 V\r\n")]
    assert ex[4].output[-1] == (1.0, b"P2>")


def test_mock_answers_in_order_and_reports_departures():
    out: list = []
    logs: list = []
    mock = MockHat(read_transcript(io.StringIO(recording())), out.append, speed=50, log=logs.append)
    mock.start()
    assert mock.feed(b"version\r") == []
    assert mock.feed(b"vin") == [] and mock.feed(b"x\r") == [b"vinx\r"]   # departs: no answer
    assert mock.feed(b"vin\r") == []
    deadline = time.monotonic() + 5
    while not mock.idle() and time.monotonic() < deadline:
        time.sleep(0.01)
    mock.close()
    stream = b"".join(out)
    assert stream.endswith(b"\r\n" + VERSION + b"\r\n\r\n7.20 V\r\n")
    assert stream.count(b"7.20 V") == 1
    assert any("vinx" in m and "expected b'vin\\r'" in m for m in logs)
    assert mock.departures == [b"vinx\r"] and mock.matched == 2


def test_mock_moves_on_when_the_host_skips_a_recorded_line():
    out: list = []
    logs: list = []
    mock = MockHat(read_transcript(io.StringIO(recording())), out.append, speed=50, log=logs.append)
    mock.start()
    assert mock.feed(b"vin\r") == []          # `version` skipped
    assert mock.skipped == [b"version\r"] and "did not send" in logs[0]
    mock.close()


def test_pty_serves_start_up_then_answers(tmp_path):
    stop = threading.Event()
    ready: list = []
    path = tmp_path / "recording.jsonl"
    path.write_text(recording(), encoding="utf-8")
    th = threading.Thread(target=serve_pty, args=(read_transcript(str(path)),),
                          kwargs={"speed": 20, "stop": stop, "on_ready": ready.append}, daemon=True)
    th.start()
    deadline = time.monotonic() + 5
    while not ready and time.monotonic() < deadline:
        time.sleep(0.01)
    fd = os.open(ready[0], os.O_RDWR | os.O_NOCTTY)
    try:
        assert b"Done initialising ports\r\n" in read_until(fd, b"Done initialising ports\r\n")
        os.write(fd, b"version\r")
        assert VERSION in read_until(fd, VERSION)
        os.write(fd, b"help\r")                          # not in the recording: no answer
        assert read_quiet(fd) == b""
        os.write(fd, b"vin\r")
        assert read_until(fd, b"7.20 V\r\n") == b"\r\n7.20 V\r\n"
    finally:
        os.close(fd)
        stop.set()
        th.join(5)
    assert not th.is_alive()


def test_tcp_strict_stops_at_the_first_departure(tmp_path):
    ready: list = []
    result: list = []
    transcript = read_transcript(io.StringIO(recording()))
    th = threading.Thread(target=lambda: result.append(serve_tcp(
        transcript, "127.0.0.1", 0, speed=20, strict=True, on_ready=ready.append)), daemon=True)
    th.start()
    deadline = time.monotonic() + 5
    while not ready and time.monotonic() < deadline:
        time.sleep(0.01)
    port = int(ready[0].rsplit(":", 1)[1])
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(b"version\r")
        got = b""
        while VERSION not in got:
            got += s.recv(4096)
        s.sendall(b"list\r")
        th.join(5)
    assert result == [1]


def test_command_line_prints_the_pty_path_first(tmp_path):
    path = tmp_path / "recording.jsonl"
    path.write_text(recording(), encoding="utf-8")
    proc = subprocess.Popen([sys.executable, "-m", "buildhat_conformance", "mock", str(path), "--pty",
                             "--speed", "20"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        dev = proc.stdout.readline().decode().strip()
        assert dev.startswith("/dev/pts/")
        fd = os.open(dev, os.O_RDWR | os.O_NOCTTY)
        os.write(fd, b"version\r")
        assert VERSION in read_until(fd, VERSION)
        os.close(fd)
    finally:
        proc.terminate()
        _out, err = proc.communicate(timeout=10)
    assert proc.returncode == 0
    assert b"1 host line(s) answered" in err


def test_bad_file_is_a_clear_error(tmp_path, capsys):
    from buildhat_conformance.cli import main

    bad = tmp_path / "x.jsonl"
    bad.write_text('{"t":0}\n', encoding="utf-8")
    assert main(["mock", str(bad)]) == 2
    assert "x.jsonl:1: the first line must be" in capsys.readouterr().err


@pytest.mark.parametrize("speed", [0, -1])
def test_speed_must_be_positive(speed):
    with pytest.raises(ValueError):
        MockHat(read_transcript(io.StringIO(recording())), lambda b: None, speed=speed)
