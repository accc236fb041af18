"""The suite against faulty HATs (issue 13, "Done when"): real programs (tests/faulty/faulty_hat.py,
``buildhat-emulator --stdio`` behind a link fault) as ``cmd:`` targets.

Each run must finish in bounded time with every case reported in a valid JUnit file, the
target's faults as ``target-fault`` (one line saying what it did), never ``fail``, and exit
status 3; after a single glitch (a lost or corrupted line ending, a restart, a burst of garbage,
a short flood) the following cases pass again; after N target faults in a row the rest is
``not-run`` with the reason.

The runs are started together (most of their time is waiting on a silent or deaf target) and
each runs one or two files of the suite against the emulator at --speed 20, already booted.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Dict, List

import pytest
from junit_props import suite_properties
from mutants.suite_run import REPO, SUITE, CaseResult, read_junit, reported_case_count

pytestmark = pytest.mark.timeout(240)

FAULTY = os.path.join(REPO, "tests", "faulty", "faulty_hat.py")
EMULATOR = ["--", "--booted", "--speed", "20"]
RUN_LIMIT_S = 180      # a bound, not a measurement: a run that hangs fails here instead of at pytest-timeout

# name: (faulty_hat.py arguments, suite files, extra suite options)
RUNS = {
    # One glitch of each kind in turn, each on a line a test case sends (`vin`), with cases between,
    # and a short flood last. No stop after N faults in a row: on a loaded machine the harness
    # reads the flood slowly, so it can reach into several cases.
    "glitches": (["drop,corrupt,reboot,garbage,flood", "--after", "0", "--gap", "10", "--on", "vin",
                  "--garbage-mb", "0.5", "--flood-lines", "300"],
                 ["test_link.py", "test_separators.py"], ["--max-target-faults", "0"]),
    "silent": (["silent", "--after", "0", "--on", "vin"], ["test_link.py"], ["--max-target-faults", "2"]),
    "deaf": (["deaf", "--after", "0", "--on", "vin"], ["test_link.py"], ["--max-target-faults", "1"]),
    "exit": (["exit", "--after", "0", "--on", "vin"], ["test_link.py"], []),
    "flood": (["flood", "--after", "0", "--on", "vin"], ["test_link.py"], []),
}


@dataclass
class Run:
    status: int
    seconds: float
    output: str
    cases: List[CaseResult]
    log: str
    stopped: str = ""
    verdicts: List[str] = field(default_factory=list)


def _start(tmp: str, name: str) -> subprocess.Popen:
    args, files, extra = RUNS[name]
    folder = os.path.join(tmp, name)
    os.makedirs(folder)
    target = "cmd:" + " ".join([sys.executable, FAULTY, *args, "--log", os.path.join(folder, "fired.log"),
                                *EMULATOR])
    argv = [sys.executable, "-m", "pytest", *[os.path.join(SUITE, f) for f in files],
            "-p", "no:cacheprovider", "-p", "no:hypothesispytest", "--rootdir", SUITE,
            "--import-mode=importlib", "-q", "--target", target,
            "--conformance-junit", os.path.join(folder, "junit.xml"),
            "--transcripts", os.path.join(folder, "transcripts"), *extra]
    return subprocess.Popen(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> Dict[str, Run]:
    tmp = str(tmp_path_factory.mktemp("faulty"))
    began = time.monotonic()
    procs = {name: _start(tmp, name) for name in RUNS}
    out: Dict[str, Run] = {}
    deadline = time.monotonic() + RUN_LIMIT_S
    for name, proc in procs.items():
        try:
            text, _ = proc.communicate(timeout=max(1.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            for p in procs.values():
                p.kill()
            pytest.fail(f"the run against the {name!r} HAT did not finish in {RUN_LIMIT_S} s")
        folder = os.path.join(tmp, name)
        junit = os.path.join(folder, "junit.xml")
        cases = list(read_junit(junit).values())
        log_path = os.path.join(folder, "fired.log")
        log = open(log_path, encoding="utf-8").read() if os.path.exists(log_path) else ""
        suite = ET.parse(junit).getroot().find("testsuite")
        assert suite is not None
        props = suite_properties(suite)
        out[name] = Run(proc.returncode, time.monotonic() - began, text.decode(errors="replace"), cases, log,
                        props.get("stopped", ""), [c.verdict for c in cases])
    return out


def _reported(run: Run) -> int:
    """How many cases pytest itself says it ran (its summary line)."""
    return reported_case_count(run.output)


@pytest.mark.parametrize("name", list(RUNS))
def test_every_case_is_reported_and_no_fault_is_a_failure(runs: Dict[str, Run], name: str) -> None:
    run = runs[name]
    assert run.log, f"the {name} fault never fired:\n{run.output[-2000:]}"
    assert len(run.cases) == _reported(run) > 0, run.output[-2000:]
    assert "fail" not in run.verdicts, [(c.name, c.message[:300]) for c in run.cases if c.verdict == "fail"]
    assert "target-fault" in run.verdicts, run.verdicts
    assert run.verdicts[0] in ("pass", "informational"), "the cases before the fault pass"
    for case in run.cases:
        if case.verdict == "target-fault":
            first = case.message.splitlines()[0]
            assert first.startswith("target fault (") and "Traceback" not in first, first
            assert " at 0x" not in first, first         # never a repr of the Hat object
    assert run.status == 3, f"exit status {run.status}, not 3 (target faulted)"


def test_after_each_single_glitch_the_following_cases_pass(runs: Dict[str, Run]) -> None:
    run = runs["glitches"]
    fired = [line.split()[0] for line in run.log.splitlines() if " fired after " in line]
    assert fired == ["drop", "corrupt", "reboot", "garbage", "flood"], run.log
    lines = [c.message.splitlines()[0] if c.message else "" for c in run.cases]
    flood = next(i for i, line in enumerate(lines) if "flood" in line)
    single = [line for line in lines[:flood] if line.startswith("target fault")]
    # Each single glitch (a lost or corrupted line ending, a restart, a burst of garbage) costs
    # at most the case it hit; the cases between them pass.
    assert 3 <= len(single) <= 4, single
    for what in ("(rebooted)", "binary garbage"):
        assert any(what in line for line in single), single
    assert all(v in ("pass", "informational", "known deviation", "target-fault") for v in run.verdicts)
    assert run.verdicts[:flood].count("pass") >= flood - len(single) - 2, run.verdicts[:flood]
    # After the flood has passed, the HAT answers again and the cases pass.
    assert "not-run" not in run.verdicts and not run.stopped
    assert run.verdicts[-5:] == ["pass"] * 5, run.verdicts


def test_a_silent_hat_stops_the_run_after_n_faults_in_a_row(runs: Dict[str, Run]) -> None:
    run = runs["silent"]
    faults = [c for c in run.cases if c.verdict == "target-fault"]
    assert len(faults) == 2, run.verdicts            # --max-target-faults 2
    assert "(silent)" in faults[-1].message or "no answer" in faults[-1].message, faults[-1].message
    first = run.verdicts.index("target-fault")
    assert run.verdicts[first + 2:] and set(run.verdicts[first + 2:]) == {"not-run"}, run.verdicts
    assert "2 target faults in a row" in run.stopped
    not_run = [c for c in run.cases if c.verdict == "not-run"]
    assert all("2 target faults in a row" in c.properties.get("not_run", "") for c in not_run)


def test_a_hat_that_stops_reading_is_a_target_fault_within_seconds(runs: Dict[str, Run]) -> None:
    run = runs["deaf"]
    fault = next(c for c in run.cases if c.verdict == "target-fault")
    first = fault.message.splitlines()[0]
    assert "(not reading)" in first or "(silent)" in first, first
    assert run.verdicts[run.verdicts.index("target-fault") + 1:].count("not-run") >= 1


def test_a_hat_that_exits_is_dead_and_the_rest_is_not_run(runs: Dict[str, Run]) -> None:
    run = runs["exit"]
    fault = next(c for c in run.cases if c.verdict == "target-fault")
    assert "(dead)" in fault.message and "exited with status 1" in fault.message, fault.message
    after = run.verdicts[run.verdicts.index("target-fault") + 1:]
    assert after and set(after) == {"not-run"}, run.verdicts
    assert "went away" in run.stopped


def test_an_endless_flood_is_five_faults_then_not_run(runs: Dict[str, Run]) -> None:
    run = runs["flood"]
    faults = [c for c in run.cases if c.verdict == "target-fault"]
    assert len(faults) == 5, run.verdicts            # the default --max-target-faults
    # Named as a flood, or (when a loaded harness reads the flood only while it waits for a fence)
    # as garbled by lines no Build HAT prints: either way the target's own output is the reason.
    assert any("a flood of lines" in c.message or "no Build HAT output" in c.message for c in faults), \
        [c.message[:200] for c in faults]
    assert "5 target faults in a row" in run.stopped
