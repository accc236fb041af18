"""Ctrl-C stops `buildhat-conformance fuzz` at any moment (issue 22): while it fuzzes, while it
confirms a finding, in every worker of --jobs N. The campaign ends within seconds with exit 130,
keeps every finding found so far (its script and transcripts, marked as cut short), writes the
JUnit file (marked partial) and the summary, and leaves no process behind; a second Ctrl-C kills
it at once.

Real subprocesses, as a user runs them. The command leads its own session, so a signal to its
process group is what a terminal's Ctrl-C does (every process of the foreground group gets it);
a signal to its pid alone is `kill -INT`. /proc says which processes it started and which are left.
The confirm phase is made long by a planted always-failing target (tests/planted/proxy.py
`wrong`: every `coast` also prints `Error`) and thousands of confirming replays."""
from __future__ import annotations

import ast
import os
import pathlib
import re
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from typing import Dict, Optional

import pytest
from junit_props import properties
from process_tree import cmdline, descendants, left_after
from repo_paths import TESTS

from buildhat_conformance.harness.transcript import read_transcript

pytestmark = [pytest.mark.skipif(not os.path.isdir("/proc"), reason="needs Linux /proc"),
              pytest.mark.timeout(400)]

EXE = os.path.join(os.path.dirname(sys.executable), "buildhat-conformance")
STOP_S = 30          # a stop must take seconds; this bound holds on a loaded machine
GRACE_S = 2.0        # what a target that ignores SIGTERM is given before SIGKILL (its close)
PROGRESS = re.compile(r"^\[fuzz\] \d+/\d+ s: [1-9]\d* inputs", re.M)
LONG = ["--budget", "10m", "--no-database", "--seed", "4"]


def _proxy(prefix: str = "") -> str:
    """The planted `wrong` fault as a `cmd:` target (a byte proxy around `buildhat-emulator --stdio`)."""
    return (f"cmd:{prefix}{sys.executable} {TESTS / 'planted' / 'proxy.py'} wrong "
            "--device 0=none --device 1=none --device 2=none --device 3=none")


# Confirming takes as long as the test wants: thousands of replays, no bound on checking.
CONFIRMING = ["--families", "valid", "--steps", "4", "--batch", "4", "--waits", "", "--confirm", "100000",
              "--check-time", "1h"]


class Fuzz:
    """`buildhat-conformance fuzz` running in a session of its own, its output in files."""

    def __init__(self, tmp_path: pathlib.Path, *args: str, env: Optional[dict] = None):
        self.out = tmp_path / "out"
        self.stdout, self.stderr = tmp_path / "stdout.txt", tmp_path / "stderr.txt"
        with open(self.stdout, "wb") as out, open(self.stderr, "wb") as err:
            self.proc = subprocess.Popen([EXE, "fuzz", "-o", str(self.out), *args], stdout=out, stderr=err,
                                         start_new_session=True, env=env)
        self.started: Dict[int, str] = {}      # every process it started: pid -> command line
        self.signalled = 0.0

    def err(self) -> str:
        return self.stderr.read_text(encoding="utf-8", errors="replace")

    def note_started(self) -> None:
        for pid in descendants(self.proc.pid) - set(self.started):
            self.started[pid] = cmdline(pid)

    def wait_for(self, pattern: re.Pattern[str], within: float = 180) -> None:
        """Until stderr shows ``pattern`` (noting every process the command starts meanwhile)."""
        end = time.monotonic() + within
        while time.monotonic() < end:
            self.note_started()
            if pattern.search(self.err()):
                return
            if self.proc.poll() is not None:
                pytest.fail(f"the campaign ended (exit {self.proc.returncode}) before {pattern.pattern!r}:\n"
                            + self.err() + self.stdout.read_text(encoding="utf-8"))
            time.sleep(0.1)
        self.proc.kill()
        pytest.fail(f"no {pattern.pattern!r} within {within:g} s:\n{self.err()}")

    def interrupt(self, group: bool = True) -> None:
        self.note_started()
        self.signalled = time.monotonic()
        if group:
            os.killpg(self.proc.pid, signal.SIGINT)
        else:
            os.kill(self.proc.pid, signal.SIGINT)

    def finish(self) -> float:
        """Seconds from the (first) signal to the command's exit."""
        try:
            self.proc.wait(timeout=STOP_S)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
            pytest.fail(f"still running {STOP_S} s after Ctrl-C:\n{self.err()}")
        return time.monotonic() - self.signalled

    def summary(self) -> str:
        return self.stdout.read_text(encoding="utf-8")

    def check_nothing_left(self) -> None:
        left = left_after(set(self.started), grace=10)
        assert not left, f"left running after the campaign ended: {left}"


def _stopped_cleanly(run: Fuzz) -> None:
    """Exit 130, the summary and the JUnit file written (partial), nothing left running."""
    run.finish()
    assert run.proc.returncode == 130, run.summary() + run.err()
    assert "Traceback" not in run.err(), run.err()
    assert "[fuzz] stopping: keeping what was found" in run.err()
    summary = run.summary()
    assert re.search(r"^fuzz: \d+ runs, \d+ inputs", summary, re.M), summary
    assert "interrupted (Ctrl-C or SIGTERM)" in summary, summary
    suite = ET.parse(run.out / "junit.xml").getroot()
    props = properties(suite)
    assert props.get("partial") == "true", props
    run.check_nothing_left()


def _sil_env(tmp_path: pathlib.Path) -> dict:
    from sil_support import firmware_tree
    firmware_tree()                     # skips without the tree or a C compiler
    return dict(os.environ, BUILDHAT_SIL_CACHE=str(tmp_path / "silcache"))


@pytest.mark.parametrize("how", ["emulator-ctrl-c", "sil-against-emulator-jobs-2-kill-int"])
def test_ctrl_c_while_fuzzing_stops_within_seconds_and_leaves_nothing_running(tmp_path, how):
    if how == "emulator-ctrl-c":
        run = Fuzz(tmp_path, "-t", "emulator", "--steps", "20", *LONG)
    else:
        from sil_support import firmware_tree
        env = _sil_env(tmp_path)
        run = Fuzz(tmp_path, "-t", f"sil:{firmware_tree()}", "--against", "emulator", "--jobs", "2", *LONG,
                   env=env)
    run.wait_for(PROGRESS)
    kinds = " ".join(run.started.values())
    assert "buildhat-emulator" in kinds, kinds            # the targets' processes were running
    # A terminal's Ctrl-C reaches the whole group; `kill -INT` the command alone (its workers
    # must hear it from the command).
    run.interrupt(group=how == "emulator-ctrl-c")
    _stopped_cleanly(run)
    if how != "emulator-ctrl-c":
        assert "2 workers" in run.summary()
        assert any(line.split(" ")[0].endswith("/firmware") for line in run.started.values()), run.started


@pytest.mark.parametrize("jobs, group", [("1", True), ("2", False)], ids=["ctrl-c", "jobs-2-kill-int"])
def test_ctrl_c_while_confirming_keeps_the_finding_marked_not_fully_checked(tmp_path, jobs, group):
    run = Fuzz(tmp_path, "-t", _proxy(), "--jobs", jobs, *LONG, *CONFIRMING)
    run.wait_for(re.compile(r"a \[fate\] failure: replaying it 100000 time\(s\) to confirm it"))
    time.sleep(1.0)                                         # well inside the confirming replays
    run.interrupt(group=group)
    _stopped_cleanly(run)
    summary = run.summary()
    assert re.search(r"FINDING \[fate\] \(reproduced (\d+)/\1\b", summary), summary
    assert "checking cut short: interrupted while it was being checked" in summary, summary
    script = (run.out / "fate.script").read_text(encoding="utf-8")
    assert ";; checking cut short: interrupted" in script, script
    # Every byte the target sent in the failing step is in its transcript.
    expected = (run.out / "fate.expected.txt").read_text(encoding="utf-8")
    received = ast.literal_eval(re.search(r"^received: (b.*)$", expected, re.M).group(1))  # type: ignore[union-attr]
    assert b"Error" in received
    assert received in read_transcript(str(run.out / "fate.target.jsonl")).hat_bytes
    suite = ET.parse(run.out / "junit.xml").getroot()
    failed = {c.get("name"): c.find("failure") for c in suite.iter("testcase")
              if c.find("failure") is not None}
    assert set(failed) == {"fate"}
    assert "checking cut short: interrupted" in (failed["fate"].text or "")


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_second_ctrl_c_kills_at_once_and_still_leaves_nothing_running(tmp_path, jobs):
    """The target ignores SIGTERM and SIGINT, and outlives its stdin (the proxy inside it ends when
    its stdin closes, the first thing a close does: that made the close instant, about 1 run in 3),
    staying until its parent is gone. So closing it after the first Ctrl-C takes its 2 s grace
    before SIGKILL; the second Ctrl-C comes in that time, and the command ends there, writing
    nothing more."""
    for attempt in range(3):
        (tmp_path / str(attempt)).mkdir()
        stays = ("sh -c 'trap \"\" TERM INT; \"$0\" \"$@\"; "
                 "while kill -0 $PPID 2>/dev/null; do sleep 0.1; done' ")
        run = Fuzz(tmp_path / str(attempt), "-t", _proxy(stays),
                   "--jobs", jobs, *LONG, *CONFIRMING)
        run.wait_for(re.compile(r"replaying it 100000 time\(s\) to confirm it"))
        run.interrupt()
        run.wait_for(re.compile(r"\[fuzz\] stopping"), within=STOP_S)
        seen = time.monotonic()
        run.interrupt()
        late = time.monotonic() - seen     # a loaded machine may hold this test back past the grace
        run.finish()
        assert run.proc.returncode == 130, run.summary() + run.err()
        run.check_nothing_left()
        if late < GRACE_S / 2:
            break
    else:
        pytest.fail(f"three times the second Ctrl-C could not be sent within {GRACE_S / 2:g} s of the "
                    "first stop")
    assert not re.search(r"^fuzz: \d+ runs", run.summary(), re.M), "the second Ctrl-C waited for the summary"
