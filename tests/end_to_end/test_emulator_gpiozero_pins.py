"""The gpiozero pin factory (emulator/host_fixtures/gpiozero_pins.py), chosen the way a host library's
environment does:
``GPIOZERO_PIN_FACTORY=buildhat_emulator`` resolved through gpiozero's own entry point, the emulator found
through ``BUILDHAT_EMULATOR_CONTROL`` (+ ``_TOKEN`` on TCP) as it prints them. A real gpiozero in a child
process drives GPIO 4 (RESET, active low) as python-build-hat 0.5.x does; FIRMWARE-FACTS §9: released,
the chip starts its bootloader (the firmware lived in RAM)."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys

import pytest

pytest.importorskip("gpiozero")
pytestmark = pytest.mark.timeout(90)

CLI = [sys.executable, "-m", "buildhat_conformance.emulator.cli"]
PULSE = """
from gpiozero import DigitalOutputDevice
from buildhat_conformance.serving.control_client import ControlClient
ask = ControlClient.from_environment().request
print("before", ask("@firmware"), flush=True)
reset = DigitalOutputDevice(4, initial_value=True)      # gpiozero's own name for GPIO 4; driven high
reset.off()
print("held", ask("@firmware"), flush=True)
reset.on()
reset.close()
print("after", ask("@firmware"), flush=True)
"""


@pytest.mark.parametrize("control", ["unix", "tcp"])
def test_a_reset_pulse_through_gpiozero_brings_up_the_bootloader(tmp_path, control: str) -> None:
    address = str(tmp_path / "ctl.sock") if control == "unix" else "tcp:127.0.0.1:0"
    emu = subprocess.Popen(CLI + ["--pty", "--booted", "--control", address, "--firmware", "1636109636"]
                           + [a for p in range(4) for a in ("--device", f"{p}=none")],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        printed = dict(re.findall(r"(BUILDHAT_EMULATOR_\w+)=(\S+)", emu.stderr.readline().decode()))
        assert (control == "tcp") == ("BUILDHAT_EMULATOR_TOKEN" in printed), printed
        env = {k: v for k, v in os.environ.items() if not k.startswith("BUILDHAT_EMULATOR")}
        env.update(printed, GPIOZERO_PIN_FACTORY="buildhat_emulator")
        run = subprocess.run([sys.executable, "-c", PULSE], env=env, capture_output=True, text=True,
                             timeout=60)
        assert run.returncode == 0, run.stderr
        # R2's version string: FIRMWARE-FACTS §0; RESET low holds the chip; released, its bootloader runs.
        assert run.stdout.splitlines() == ["before ok 1636109636 2021-11-05T10:53:56+00:00", "held ok reset",
                                           "after ok bootloader"], run.stdout
    finally:
        emu.send_signal(signal.SIGTERM)
        emu.wait(20)


def test_without_the_address_gpiozero_names_the_missing_variable() -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("BUILDHAT_EMULATOR")}
    env["GPIOZERO_PIN_FACTORY"] = "buildhat_emulator"
    code = "from gpiozero import DigitalOutputDevice; DigitalOutputDevice(4)"
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert run.returncode != 0 and "BUILDHAT_EMULATOR_CONTROL is not set" in run.stderr, run.stderr
