"""The host lint end to end: a plain pyserial host on ``buildhat-emulator``'s pty, read back through the
control channel (``@lint``), at exit, and made fatal with ``--strict-host``.

The wrong host makes the mistakes of FIRMWARE-FACTS §1 (CRLF) and §11/§12 items 7-8 (``bias`` and a
10-number ``pid`` on R6+); the same lines are fine on R2 except the CRLF.
"""
from __future__ import annotations

import json
import time
from typing import List

import pytest
import serial
from hostlib.emulator_proc import EmulatorProcess  # noqa: E402

pytestmark = pytest.mark.timeout(120)

EMPTY = {0: "none", 1: "none", 2: "none", 3: "none"}
WRONG_HOST = [b"version\r\n",                                  # CRLF: the LF starts the next line
              b"vin\r",                                        # ... which is therefore "\nvin": Error
              b"port 0 ; plimit 1 ; bias .4\r",                # bias: R1-R5 only
              b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3\r"]       # the 2021 document's 10 numbers


def settle(emu: EmulatorProcess) -> None:
    emu.wait_settled()             # start-up done (about 210 ms); no devices to wait for


def talk(pty: str, lines: List[bytes], answer_wait: float = 0.3) -> bytes:
    """Send the lines; return what came back. Stops quietly if the emulator hangs up (strict mode)."""
    got = b""
    with serial.Serial(pty, 115200, timeout=0.1) as port:
        try:
            for line in lines:
                port.write(line)
                time.sleep(0.05)
            time.sleep(answer_wait)
            got = port.read(65536)
        except serial.SerialException:
            pass
    return got


def test_wrong_host_is_reported_through_the_control_channel() -> None:
    with EmulatorProcess(firmware="1737564117", devices=EMPTY) as emu:
        settle(emu)
        out = talk(emu.pty, WRONG_HOST)
        assert out.count(b"Error\r\n") == 3, out                # the HAT itself refused three lines
        summary = json.loads(emu.control("@lint"))
    counts = {k: v for k, v in summary["counts"].items() if v}
    assert counts == {"error": 3, "crlf": 1, "not_in_profile": 1, "pid_arity": 1}, summary
    lines = {f["kind"]: f["line"] for f in summary["findings"] if f["kind"] != "error"}
    assert lines == {"crlf": 2, "not_in_profile": 3, "pid_arity": 4}, summary
    assert summary["profile"] == "R7 1737564117" and not summary["clean"]


def test_same_host_on_r2_only_trips_over_crlf() -> None:
    with EmulatorProcess(firmware="1636109636", devices=EMPTY) as emu:
        settle(emu)
        talk(emu.pty, WRONG_HOST)
        summary = json.loads(emu.control("@lint"))
    assert {k: v for k, v in summary["counts"].items() if v} == {"error": 1, "crlf": 1}, summary


def test_lint_report_at_exit_names_the_lines() -> None:
    emu = EmulatorProcess(firmware="1737564117", devices=EMPTY)
    with emu:
        settle(emu)
        talk(emu.pty, WRONG_HOST)
        emu.stop()
        report = emu.stderr()
    assert "host lint" in report and "crlf=1" in report, report
    assert "'bias' is not a command of R7" in report and "line 3" in report, report


def test_strict_host_makes_the_first_finding_fatal() -> None:
    with EmulatorProcess(firmware="1737564117", devices=EMPTY, strict_host=True) as emu:
        settle(emu)
        talk(emu.pty, [b"vin\r", b"port 0 ; bias 0.3\r", b"vin\r"], answer_wait=0.1)
        code = emu.wait(timeout=10)
        message = emu.stderr()
    assert code is not None and code != 0, "--strict-host kept running after a finding"
    assert "line 2" in message and "bias" in message and "not_in_profile" in message, message


def test_strict_host_lets_a_correct_host_run() -> None:
    with EmulatorProcess(firmware="1737564117", devices=EMPTY, strict_host=True) as emu:
        settle(emu)
        out = talk(emu.pty, [b"port 0 ; port_plimit 0.7 ; pwmparams 0.65 0.01\r", b"vin\r",
                             b"pid 0 0 1 s4 0.0027777778 0 5 0 .1 3 0.01 ; coast\r"])
        assert b"Error" not in out and b" V\r\n" in out, out
        assert emu.wait(timeout=1.0) is None, emu.stderr()      # still serving
        assert json.loads(emu.control("@lint"))["clean"] is True
