"""Issue 23: `run --places` on a real labgrid lab on loopback (tests/lab_fixture.py): the suite on
two places at once, one merged report naming each case's place, and a HAT that hangs on one place
reset through that place's labgrid digital output and loaded again, while the run goes on.

Both HATs start in their bootloader, as a real one after power-on, so `run --image` loads the
release into each through labgrid first; hat-a hangs after the host's 60th line (the emulator's
fault injection), and its RESET pin is the place's HttpDigitalOutput `reset`. Skipped, with the
reason, where labgrid or ser2net is missing.
"""
from __future__ import annotations

import subprocess
import xml.etree.ElementTree as ET

import pytest
from end_to_end.test_run_reset_recovery import PI_SUBSET  # 14 cases; the hang comes in the 5th or 6th
from firmware_images import files, image_of  # noqa: E402
from junit_props import properties, suite_properties
from lab_fixture import BIN, Lab, missing  # noqa: E402


@pytest.fixture
def lab(tmp_path):
    why = missing()
    if why:
        pytest.skip(why)
    lab = Lab(tmp_path / "lab", {"hat-a": ["--bootloader", "--hang-after", "60"],
                                 "hat-b": ["--bootloader"]})
    (tmp_path / "lab").mkdir()
    lab.start()
    yield lab
    lab.stop()


@pytest.mark.timeout(600)       # real time on a loaded machine: two loads, 28 cases, a reset and a reload
def test_the_suite_runs_on_two_places_at_once_and_a_hung_hat_is_reset_through_labgrid(lab, tmp_path):
    img, sig = files(tmp_path, image_of("R7"))
    junit = tmp_path / "run" / "junit.xml"
    proc = subprocess.run([str(BIN / "buildhat-conformance"), "run", "--places", "board=buildhat",
                           "-k", PI_SUBSET, "--max-target-faults", "1", "--image", img, "--signature", sig,
                           "--junit", str(junit)],
                          env=lab.env, capture_output=True, text=True, timeout=400)
    out = proc.stdout + proc.stderr
    assert "labgrid places: hat-a, hat-b" in out, out
    root = ET.parse(junit).getroot()
    suite = suite_properties(root)
    verdicts: dict = {"hat-a": [], "hat-b": []}
    for case in root.iter("testcase"):
        props = properties(case)
        verdicts[props["target_name"]].append(props["verdict"])
        assert case.get("classname", "").startswith(props["target_name"] + "."), case.get("classname")
        assert props["target"].startswith(f"labgrid:{props['target_name']}?"), props
    assert len(verdicts["hat-a"]) == len(verdicts["hat-b"]) >= 10, verdicts
    # hat-b: nothing hung, every case passes (or is known / informational)
    assert set(verdicts["hat-b"]) <= {"pass", "known deviation", "informational"}, verdicts
    # hat-a: one target fault, then the reset through the place's output and the load again
    assert verdicts["hat-a"].count("target-fault") == 1, (verdicts, out)
    assert f"loaded {img} again; it answers again" in suite.get("hat-a:reset", ""), suite
    after = verdicts["hat-a"][verdicts["hat-a"].index("target-fault") + 1:]
    assert len(after) >= 5 and set(after) <= {"pass", "known deviation", "informational"}, verdicts
    assert any(line == "hat-a reset 0" for line in lab.outputs.log), lab.outputs.log
    assert not any(line.startswith("hat-b") for line in lab.outputs.log), lab.outputs.log
    assert proc.returncode == 3, out          # a target fault happened; nothing failed the protocol
    assert lab.holder("hat-a") == "" and lab.holder("hat-b") == ""
