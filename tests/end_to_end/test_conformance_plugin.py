"""The plugin's contract, seen from outside: per-case JUnit properties, skip reasons on a
target without world control (the position of a real HAT on a bench), the summary."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest
from mutants.suite_run import REPO, SUITE, read_junit

pytestmark = pytest.mark.timeout(300)


def test_plain_target_skips_world_actions_and_records_every_case(tmp_path) -> None:
    emulator = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
    # Bytes only: no control channel. Started booted: the start-up is not what this test is about.
    target = f"cmd:{emulator} --stdio --booted --firmware R5"
    junit = tmp_path / "junit.xml"
    cases = ["test_commands.py::test_vin_follows_the_supply_and_rounds_a_5_down[0]",
             "test_commands.py::test_vin_prints_volts_with_two_decimals",
             "test_events.py::test_passive_device_connect_message",
             "test_select.py::test_selonce_variable_reports_once"]
    argv = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--import-mode=importlib", "-rs",
            *[os.path.join(SUITE, c) for c in cases], "--target", target,
            "--conformance-junit", str(junit), "--transcripts", str(tmp_path / "tr")]
    proc = subprocess.run(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=280)
    out = proc.stdout.decode(errors="replace")
    results = read_junit(str(junit))
    verdicts = {n: r.verdict for n, r in results.items()}
    assert verdicts == {
        "test_vin_follows_the_supply_and_rounds_a_5_down[0]": "skip",
        "test_vin_prints_volts_with_two_decimals": "pass",
        "test_passive_device_connect_message": "skip",
        "test_selonce_variable_reports_once": "pass",         # R5 reports once: as the document says
    }, out[-3000:]
    assert "needs control of the input voltage" in out and "needs plugging a device in" in out
    for r in results.values():
        props = r.properties
        assert props["target"] == target and props["profile"] == "R5"
        assert props["firmware"].startswith("1670596313 ") and props["requirements"]
        assert os.path.exists(props["transcript"])
    assert "conformance by requirement area" in out and "requirement IDs with no test run" in out
    assert proc.returncode == 0, "skips are not failures"
