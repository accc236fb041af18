"""Two failing tests of a wrong host, as in a library's suite: under --strict-host the emulator stops at
its first bad line and the host sees only an I/O error; without it, the test fails on its own while the
emulator runs. Either failure message must name the offending line
(tests/end_to_end/test_hostlib_fixture.py runs this in its own pytest session and reads its report)."""
import time

import pytest
import serial


@pytest.mark.buildhat_emulator(firmware="1737564117", devices={0: None, 1: None, 2: None, 3: None},
                               args=["--strict-host", "--booted"])
def test_a_host_that_speaks_the_old_dialect(buildhat_emulator):
    with serial.Serial(buildhat_emulator.path, 115200, timeout=0.2) as port:
        port.write(b"version\r")
        port.read(200)
        port.write(b"port 0 ; bias 0.3\r")     # R1-R5 only: R7 answers Error
        time.sleep(0.5)
        port.write(b"vin\r")
        assert b" V\r\n" in port.read(200)


@pytest.mark.buildhat_emulator(firmware="1737564117", devices={0: None, 1: None, 2: None, 3: None},
                               args=["--booted"])
def test_a_failing_test_shows_its_lint_findings(buildhat_emulator):
    with serial.Serial(buildhat_emulator.path, 115200, timeout=0.2) as port:
        port.write(b"port 0 ; plimit 1 ; bias 0.4\r")     # bias: R1-R5 only
        got = b""
        while b"Error" not in got:
            got += port.read(200)
    assert b"Error" not in got, "the host's own check fails; the emulator is still running"
