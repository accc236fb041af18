"""Back-pressure under ``--baud``: the emulator takes host bytes no faster than the wire, so a host's write
into the pty (or the TCP socket) blocks the way a write into a real 115200-baud UART does.

The host here is a real pyserial port on the emulator's pty (and a real TCP socket), written from a separate
thread, with wall time measured. Only lower bounds are asserted (a loaded machine makes writes slower, never
faster). The bound subtracts what the link itself can hold before the writer blocks, measured on this
kernel: a pty's buffer (about 18 KB on Linux) is slack no emulator can take away, so a 51 KB write at
115200 baud takes at least (51 KB - that slack) / 11520 B/s; a real UART's 4 KB transmit buffer gives
(51 KB - 4 KB) / 11520 B/s = 4.1 s. What no buffer hides: the HAT has the last byte only after the whole
upload crossed the wire, so the answer to the line after it comes at least 51 KB / 11520 B/s = 4.5 s after
the write began (the figure of issue 14: 4.4 s), and the emulator's transcript shows its first and last
upload bytes that far apart.
"""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import termios
import time
import tty

import pytest
import serial

from buildhat_conformance.harness.transcript import read_transcript

pytestmark = pytest.mark.timeout(120)

BAUD = 115200
RATE = BAUD / 10            # bytes per second on an 8N1 wire
PAYLOAD = 51 * 1024         # the Go library's upload in issue 14
AHEAD = 128                 # bytes the emulator takes ahead of the wire (a few ms; uart.py WIRE_AHEAD_MS)


def pty_slack() -> int:
    """Bytes a raw pty on this kernel takes from its slave side while nobody reads the master."""
    master, slave = os.openpty()
    try:
        tty.setraw(slave, termios.TCSANOW)
        os.set_blocking(slave, False)
        total = 0
        try:
            while True:
                total += os.write(slave, b"#" * 1024)
        except BlockingIOError:
            pass
        return total
    finally:
        os.close(master)
        os.close(slave)


def start(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "buildhat_conformance.emulator.cli", "--booted", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)


def stop(proc: subprocess.Popen) -> str:
    proc.terminate()
    try:
        _, err = proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    return err.decode(errors="replace")


VERSION = b"Firmware version: "


def timed_write(port_path: str, answer: bool = False) -> tuple:
    """(seconds the write() call took, seconds until the HAT answered the line after it, or None)."""
    # No CR: the firmware keeps the first 256 bytes of the line and discards the rest, printing nothing.
    with serial.Serial(port_path, BAUD, timeout=0.1) as port:
        started = time.monotonic()
        port.write(b"#" * PAYLOAD)
        wrote = time.monotonic() - started
        if not answer:
            return wrote, None
        port.write(b"\rversion\r")            # ends the junk line (Error), then asks
        got = b""
        deadline = time.monotonic() + 60
        while VERSION not in got and time.monotonic() < deadline:
            got += port.read(4096)
        assert VERSION in got, got
        return wrote, time.monotonic() - started


def test_a_51kb_write_to_the_pty_waits_for_the_wire(tmp_path) -> None:
    slack = pty_slack()
    transcript = tmp_path / "t.jsonl"
    proc = start("--pty", "--baud", str(BAUD), "--transcript", str(transcript))
    try:
        path = proc.stdout.readline().decode().strip()
        wrote, answered = timed_write(path, answer=True)
    finally:
        err = stop(proc)
    floor = (PAYLOAD - slack - AHEAD) / RATE
    assert wrote >= floor, (wrote, floor, slack, err)
    assert floor > 2.0, (slack, "this kernel's pty buffer leaves too little to measure")
    assert answered >= PAYLOAD / RATE, (answered, err)      # >= 4.5 s: the whole upload's wire time
    upload = [e["t"] for e in read_transcript(transcript).events if e["dir"] == "host" and "#" in e["bytes"]]
    assert upload[-1] - upload[0] >= (PAYLOAD - AHEAD) / RATE * 1000 - 1, (upload[0], upload[-1])


def test_unpaced_stays_the_default() -> None:
    """Without --baud the emulator reads whatever arrives: the same write does not wait for any wire.
    (A generous upper bound: it only has to tell 'no pacing' from 'pacing', which needs 2.9 s and more.)"""
    proc = start("--pty")
    try:
        path = proc.stdout.readline().decode().strip()
        elapsed, _ = timed_write(path)
    finally:
        stop(proc)
    assert elapsed < 60


def test_the_tcp_window_closes_too() -> None:
    proc = start("--tcp", "127.0.0.1:0", "--baud", str(BAUD))
    try:
        host, _, port = proc.stdout.readline().decode().strip().rpartition(":")
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)   # a host with a UART-sized buffer
            sock.connect((host, int(port)))
            held = sock.getsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF)
            started = time.monotonic()
            sock.sendall(b"#" * PAYLOAD)
            elapsed = time.monotonic() - started
            sock.sendall(b"\rversion\r")
            sock.settimeout(60)
            got = b""
            while VERSION not in got:
                chunk = sock.recv(4096)
                assert chunk, got
                got += chunk
            answered = time.monotonic() - started
    finally:
        err = stop(proc)
    # What the two sockets hold: the sender's buffer and the receiver's (kernel-doubled, small) window.
    floor = (PAYLOAD - held - 2 * 8192 - AHEAD) / RATE
    assert elapsed >= floor, (elapsed, floor, held, err)
    assert answered >= PAYLOAD / RATE, (answered, err)
