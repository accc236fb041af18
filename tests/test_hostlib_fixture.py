"""The ``buildhat_emulator`` pytest fixture (emulator/pytest_fixture.py) used the way a host library's own
test suite would: a plain pyserial host, and the real python-build-hat library pointed at its pty."""
from __future__ import annotations

import json
import pathlib
import sys
import time

import pytest
import serial

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from hostlib.lpf2data import data_line  # noqa: E402
from hostlib.scenario import run_scenario  # noqa: E402
from hostlib.venvs import HostLibUnavailable, buildhat_python  # noqa: E402

pytestmark = pytest.mark.timeout(120)


def read_until(port: serial.Serial, marker: bytes, seconds: float) -> bytes:
    got = b""
    deadline = time.monotonic() + seconds
    while marker not in got and time.monotonic() < deadline:
        got += port.read(4096)
    return got


@pytest.mark.buildhat_emulator(firmware="1737564117", devices={0: "0x3E", 1: None, 2: None, 3: None},
                               speed=10)   # this host has no waits of its own to respect
def test_pyserial_host_reads_what_the_fixture_sets(buildhat_emulator) -> None:
    assert buildhat_emulator.control(data_line(0, 0x3E, 0, [321])) == "ok"
    with serial.Serial(buildhat_emulator.path, 115200, timeout=0.1) as port:
        port.write(b"port 0 ; set -1 ; select 0 ; selrate 50\r")
        out = read_until(port, b"P0M0: +321", 3.0)  # signed: DEVICES.md
        port.write(b"port 0 ; select\r")
    assert b"P0M0: +321\r\n" in out, out
    assert json.loads(buildhat_emulator.control("@lint")[3:])["clean"] is True


@pytest.mark.buildhat_emulator(firmware="1737564117", devices={0: "0x3E", 1: None, 2: None, 3: None},
                               baud=115200)   # wire-rate pacing, as tests/hostlib/matrix.py explains
def test_real_library_on_the_fixture(buildhat_emulator) -> None:
    try:
        python = buildhat_python("0.9.0")
    except HostLibUnavailable as exc:
        pytest.skip(f"buildhat 0.9.0 could not be installed: {exc}")
    assert buildhat_emulator.control(data_line(0, 0x3E, 0, [777])) == "ok"
    result = run_scenario(python, "distance_once.py", buildhat_emulator.path,
                          buildhat_emulator.control_path, {}, timeout=40)
    assert result.values.get("distance") == 777, result.explain()


@pytest.mark.buildhat_emulator(firmware="1737564117", devices={0: None, 1: None, 2: None, 3: None},
                               args=["--strict-host"])
def test_fixture_with_strict_host_stops_a_wrong_host(buildhat_emulator) -> None:
    with serial.Serial(buildhat_emulator.path, 115200, timeout=0.1) as port:
        port.write(b"port 0 ; bias 0.3\r")
        time.sleep(0.3)
    code = buildhat_emulator.process.wait(timeout=10)
    assert code != 0
