"""SIGINT, SIGTERM or SIGKILL of `buildhat-conformance run` ends its pytest child and every
process it started (the emulator included); Ctrl-C and SIGTERM keep the partial JUnit, marked
partial, and still build the HTML report. Real processes; /proc says what is left."""
from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest
from process_tree import alive, cmdline, descendants, left_after

pytestmark = pytest.mark.skipif(not os.path.isdir("/proc"), reason="needs Linux /proc")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL], ids=lambda s: s.name)
def test_a_signal_ends_everything_the_run_started(tmp_path: pathlib.Path, sig):
    junit = tmp_path / "r" / "junit.xml"
    # real time: the run is still going when the signal comes (booted: no start-up to wait for)
    proc = subprocess.Popen([sys.executable, "-m", "buildhat_conformance", "run", "-t",
                             "emulator?speed=1&booted=1", "--junit", str(junit)],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    started: set = set()
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:
        started |= descendants(proc.pid)
        emulators = [p for p in alive(started) if "buildhat-emulator" in cmdline(p)]
        if emulators and junit.exists() and "<testcase" in junit.read_text(encoding="utf-8"):
            break
        time.sleep(0.1)
    else:
        proc.kill()
        pytest.fail("the run did not start a case within 90 s")
    assert any("pytest" in cmdline(p) for p in started)
    started |= descendants(proc.pid)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    left = left_after(started, 30)
    assert not left, f"left running after {sig.name}: {left}"
    text = junit.read_text(encoding="utf-8")
    assert '<property name="partial" value="true"' in text, "an interrupted run's JUnit says it is partial"
    if sig != signal.SIGKILL:
        assert proc.returncode == 130
        assert "Traceback" not in err
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and "interrupted" in lines[0], err
        assert (tmp_path / "r" / "index.html").exists(), out


def test_a_complete_run_is_not_marked_partial(tmp_path: pathlib.Path):
    junit = tmp_path / "junit.xml"
    rc = subprocess.call([sys.executable, "-m", "buildhat_conformance", "run", "-t", "inprocess", "-k",
                          "test_version", "--junit", str(junit)], cwd=tmp_path, stdout=subprocess.DEVNULL)
    assert rc == 0
    assert 'name="partial"' not in junit.read_text(encoding="utf-8")
