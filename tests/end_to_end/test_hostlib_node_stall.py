"""A Node.js client that waits for the stall line after `list` connects on every release.

Issue 14: a Node library sends `list` and waits for `deltat=XXXXXXXX` before it proceeds
(FIRMWARE-FACTS §5: a real HAT prints `deltat=00000003` right after the `list` of three active
devices: a motor, a distance sensor, a colour sensor). The client (tests/nodehost/) is a real
Node program on the emulator's real pty; it uses only Node's standard library.
"""
from __future__ import annotations

import json
import shutil
import subprocess

import pytest
from hostlib.emulator_proc import EmulatorProcess  # noqa: E402
from repo_paths import TESTS  # noqa: E402

from buildhat_conformance.protocol.profiles import profile_numbers

CLIENT = TESTS / "nodehost" / "list_then_deltat.js"
NODE = shutil.which("node")
THREE = {0: "0x30", 1: "0x3E", 2: "0x3D", 3: "none"}       # the capture's three devices

pytestmark = [pytest.mark.timeout(120),
              pytest.mark.skipif(NODE is None, reason="node is not installed")]


@pytest.mark.parametrize("firmware", profile_numbers())
def test_node_client_waiting_for_deltat_after_list_connects(firmware):
    assert NODE is not None                   # the skipif above
    with EmulatorProcess(firmware=str(firmware), devices=THREE, extra=["--booted"]) as emu:
        done = subprocess.run([NODE, str(CLIENT), emu.pty, "10000"], capture_output=True,
                              text=True, timeout=60)
        assert done.returncode == 0, f"client: {done.stderr.strip()}\nemulator: {emu.stderr()}"
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["version"].startswith(f"Firmware version: {firmware} ")
    assert result["deltat"] == "deltat=00000003"
    assert [line[:3] for line in result["listLines"] if "connected to active" in line] == \
        ["P0:", "P1:", "P2:"]
    assert result["vin"].endswith(" V")
