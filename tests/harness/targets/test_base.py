"""Every target's writes have a deadline: a target that stops reading is found out within
seconds (NotReading), never by blocking the harness (issue 13, item 5).

Real parts: a child process that never reads its stdin, and a real pty whose other end is
never read, behind the same targets the suite uses.
"""
from __future__ import annotations

import os
import sys
import time

import pytest
from target_kinds import make_target_of

from buildhat_conformance.conformance.target_fault import NOT_READING, target_fault_of
from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.targets.base import WRITE_DEADLINE_S, NotReading
from buildhat_conformance.harness.targets.cmd import CommandTarget
from buildhat_conformance.harness.targets.serial_device import SerialTarget

pytestmark = pytest.mark.timeout(60)

DEADLINE = 0.3          # short, so the tests stay fast; the default is WRITE_DEADLINE_S
MUCH = b"x" * (4 << 20)  # far more than any pipe or tty buffer holds


def test_the_default_deadline_is_seconds_not_minutes() -> None:
    assert 1.0 <= WRITE_DEADLINE_S <= 10.0


def test_a_command_that_stops_reading_is_found_out_at_the_deadline() -> None:
    target = make_target_of(CommandTarget, f"cmd:{sys.executable} -c 'import time; time.sleep(60)'")
    target.write_deadline = DEADLINE
    target.open()
    try:
        began = time.monotonic()
        with pytest.raises(NotReading) as info:
            target.write(MUCH)
        took = time.monotonic() - began
        assert "stopped reading" in str(info.value) and "not taken in 0.3 s" in str(info.value)
        assert took < 30, f"the write blocked for {took:.1f} s"
        # The suite reports it as what the target did, in one line.
        fault = target_fault_of(info.value)
        assert fault.kind == NOT_READING and "\n" not in fault.what
        proc = target.proc
    finally:
        target.close()
    assert proc is not None and proc.poll() is not None, "close() ends the child"


def test_a_command_that_reads_gets_everything(tmp_path) -> None:
    # The deadline is for a target that takes nothing; one that reads slowly gets all its bytes.
    script = tmp_path / "count.py"
    script.write_text("import sys, time\nn = 0\nwhile True:\n    b = sys.stdin.buffer.read1(4096)\n"
                      "    n += len(b)\n    time.sleep(0.001)\n    if not b:\n        break\n"
                      "print(n, flush=True)\n")
    target = make_target_of(CommandTarget, f"cmd:{sys.executable} {script}")
    target.write_deadline = 5.0
    target.open()
    try:
        target.write(MUCH[: 1 << 20])
        assert target.proc is not None and target.proc.stdin is not None
        target.proc.stdin.close()          # EOF: the child prints how much it read
        out = b""
        deadline = time.monotonic() + 20
        while not out.endswith(b"\n") and time.monotonic() < deadline:
            out += target.read(1.0)
        assert out.strip() == str(1 << 20).encode()
    finally:
        target.close()


def test_a_serial_port_nobody_reads_is_found_out_at_the_deadline() -> None:
    master, slave = os.openpty()
    target = SerialTarget(os.ttyname(slave), exclusive=False)
    target.write_deadline = DEADLINE
    target.open()
    try:
        began = time.monotonic()
        with pytest.raises(NotReading, match="stopped reading"):
            target.write(MUCH)
        assert time.monotonic() - began < 30
    finally:
        target.close()
        os.close(master)
        os.close(slave)


def test_a_socket_nobody_reads_is_found_out_at_the_deadline() -> None:
    import socket

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    target = make_target(f"socket://127.0.0.1:{server.getsockname()[1]}")
    target.write_deadline = DEADLINE
    target.open()
    peer, _ = server.accept()        # accepted, never read
    try:
        began = time.monotonic()
        with pytest.raises(NotReading, match="stopped reading"):
            for _ in range(16):      # the kernel's socket buffers hold a few MB
                target.write(MUCH)
        assert time.monotonic() - began < 30
    finally:
        target.close()
        peer.close()
        server.close()
