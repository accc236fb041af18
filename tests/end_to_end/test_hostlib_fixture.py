"""The ``buildhat_emulator`` pytest fixture (emulator/host_fixtures/pytest_plugin.py) used the way a host
library's own
test suite would: a plain pyserial host, and the real python-build-hat library pointed at its pty."""
from __future__ import annotations

import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time

import pytest
import serial
from hostlib.firmware_values import vin_volts  # noqa: E402
from hostlib.lpf2data import data_line  # noqa: E402
from hostlib.scenario import run_scenario  # noqa: E402
from hostlib.venvs import buildhat_python  # noqa: E402
from repo_paths import TESTS  # noqa: E402

pytestmark = pytest.mark.timeout(180)
CASES = TESTS / "hostlib" / "fixture_cases"


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


@pytest.mark.network
@pytest.mark.buildhat_emulator(firmware="1737564117", devices={0: "0x3E", 1: None, 2: None, 3: None},
                               baud=115200, args=["--booted"])   # wire-rate pacing: tests/hostlib/matrix.py
def test_real_library_on_the_fixture(buildhat_emulator) -> None:
    python = buildhat_python("0.9.0")       # from PyPI: a failed install fails (the test is marked)
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


def run_case(python: str, case: str, tmp_path: pathlib.Path, env: dict, timeout: float = 150):
    """Run one of hostlib/fixture_cases/ as its own pytest session in a scratch directory (so that only the
    plugin, not this repository's conftest, is in play), as a host library's CI would. Other plugins are
    not loaded (they cost seconds of start-up here); the fixture's own entry point is tested above."""
    target = tmp_path / f"test_{case}"
    shutil.copy(CASES / case, target)
    return subprocess.run([python, "-m", "pytest", "-v", "-p", "no:cacheprovider",
                           "-p", "buildhat_conformance.emulator.host_fixtures.pytest_plugin", target.name,
                           "--basetemp", str(tmp_path / "basetemp")],
                          cwd=tmp_path, env={**os.environ, "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1", **env},
                          capture_output=True, text=True, timeout=timeout)


def test_a_strict_host_failure_names_the_offending_line_and_keeps_the_transcript(tmp_path) -> None:
    done = run_case(sys.executable, "strict_host.py", tmp_path, {})
    out = done.stdout + done.stderr
    assert done.returncode == 1 and "2 failed" in out, out
    # The host's second line is the R1-R5 word `bias` (FIRMWARE-FACTS §11): named, with its text and reason.
    assert "--strict-host: line 2" in out and "'port 0 ; bias 0.3'" in out and "not_in_profile" in out, out
    kept = re.search(r"transcript \(every byte both ways, lint findings as notes\): (\S+)", out)
    assert kept, out
    events = [json.loads(line) for line in pathlib.Path(kept.group(1)).read_text().splitlines()]
    host = "".join(e.get("bytes", "") for e in events if e.get("dir") == "host")
    notes = [e["text"] for e in events if e.get("dir") == "note"]
    assert "bias 0.3" in host and any("not_in_profile" in n for n in notes), events[-5:]
    # A test that fails on its own while the emulator runs: its section lists that test's findings.
    assert "host lint: 2 finding(s) in this test" in out, out
    assert "line 1 (t=" in out and "'port 0 ; plimit 1 ; bias 0.4': not_in_profile" in out, out


@pytest.mark.network
def test_one_pytest_session_of_the_real_library_on_the_shared_emulator(tmp_path) -> None:
    python = buildhat_python("0.9.0")       # from PyPI: a failed install fails (the test is marked)
    adc = 1650     # and 1742, the documented default (8.00 V); the motor within the library's own 10 degrees
    case = {"options": {"firmware": "1737564117", "devices": {0: "0x30", 1: "0x3E", 2: None, 3: None},
                        "baud": 115200, "args": ["--booted"]},
            "adc": adc, "vin": vin_volts(adc), "vin_default": vin_volts(1742),
            "distance_port": "B", "distance": 777, "distance_line": data_line(1, 0x3E, 0, [777]),
            "motor_port": "A", "degrees": 90, "speed": 30, "tolerance": 10}
    done = run_case(str(python), "library_session.py", tmp_path, {
        "BUILDHAT_CASE": json.dumps(case), "GPIOZERO_PIN_FACTORY": "mock",
        "BUILDHAT_EMULATOR": f"{sys.executable} -m buildhat_conformance.emulator.cli"})
    out = done.stdout + done.stderr
    assert done.returncode == 0 and "4 passed" in out, out
    # The library's exit handler still found the emulator: no traceback from a closed pty.
    assert "Traceback" not in out and "Exception ignored" not in out and "Errno 5" not in out, out
