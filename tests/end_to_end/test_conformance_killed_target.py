"""A target that dies mid-run still leaves a complete, valid JUnit file and the transcripts
of everything received."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import pytest
from junit_props import properties
from mutants.suite_run import MUTANT, REPO, SUITE, reported_case_count

from buildhat_conformance.harness.transcript import read_transcript

pytestmark = pytest.mark.timeout(300)


def test_killing_the_target_mid_run(tmp_path) -> None:
    junit, transcripts, pidfile = tmp_path / "junit.xml", tmp_path / "tr", tmp_path / "pid"
    env = dict(os.environ, BUILDHAT_EMULATOR=f"{sys.executable} {MUTANT} none", MUTANT_PIDFILE=str(pidfile))
    child = subprocess.Popen(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--import-mode=importlib", "-q",
         os.path.join(SUITE, "test_commands.py"),
         "--target", "emulator:R7", "--conformance-junit", str(junit), "--transcripts", str(transcripts)],
        cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    # Kill the HAT once a few cases have finished.
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if junit.exists() and len(list(ET.parse(junit).getroot().iter("testcase"))) >= 5:
            break
        time.sleep(0.1)
    os.kill(int(pidfile.read_text()), signal.SIGTERM)
    out, _ = child.communicate(timeout=240)
    text = out.decode(errors="replace")
    assert child.returncode == 3, f"a run whose target died exits 3 (target faulted)\n{out[-800:]!r}"
    cases = list(ET.parse(junit).getroot().iter("testcase"))      # parses: the file is valid XML
    verdicts = [properties(c).get("verdict") for c in cases]
    # A dead HAT is a fault of the target, never a conformance failure (issue 13); the rest is not run.
    assert verdicts.count("pass") >= 5 and "target-fault" in verdicts and "fail" not in verdicts, verdicts
    assert verdicts[-1] == "not-run", verdicts
    assert "went away" in ET.tostring(ET.parse(junit).getroot(), encoding="unicode") or "Target" in text
    # One transcript per case; each is valid JSONL, and each passed case's holds the HAT's lines.
    for case, verdict in zip(cases, verdicts):
        path = properties(case).get("transcript")
        if path and os.path.exists(path):
            t = read_transcript(path)
            if verdict == "pass":
                assert t.hat_lines(), f"{path} holds no HAT output"
    # Every case pytest ran is in the file: its own summary line counts them.
    ran = reported_case_count(text)
    assert len(cases) == ran > 0, f"{len(cases)} cases in the JUnit file, pytest ran {ran}\n{text[-1500:]}"
