"""A wrong host under --strict-host, as a library's test: the emulator stops at its first bad line, the host
then sees only an I/O error, and the failure message must name the line (tests/test_hostlib_fixture.py runs
this in its own pytest session and reads its report)."""
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
