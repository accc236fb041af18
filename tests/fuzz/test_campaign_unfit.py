"""A fuzz campaign that could not do its job says so in one line and exits 3 (issue 24): a target
that answers as another release than --firmware (checked before any budget is spent), a target
that takes no input; repeated notes are printed once with a count; the wire share only for a wire.
"""
from __future__ import annotations

import io
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from buildhat_conformance.fuzz.oracles.registry import finding_class
from buildhat_conformance.fuzz.running.campaign import Budget, CampaignResult, not_done
from buildhat_conformance.fuzz.running.checked_run import Stats
from buildhat_conformance.fuzz.summary import Progress, print_summary

EXE = os.path.join(os.path.dirname(sys.executable), "buildhat-conformance")
EMULATOR = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")


def _fuzz(tmp_path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([EXE, "fuzz", "--out", str(tmp_path), "--no-database", *args],
                          capture_output=True, text=True, timeout=180)


def _lines(text: str) -> list:
    return [line for line in text.splitlines() if line.strip()]


@pytest.mark.parametrize("argv,runs,judged", [
    (["--target", "inprocess:R2", "--firmware", "R7"], "R2", "R7"),
    (["-t", "inprocess", "--firmware", "R2"], "R7", "R2"),         # the default target is the latest
    (["-t", "emulator:R2", "--firmware", "R7"], "R2", "R7"),
])
def test_a_target_of_another_release_than_firmware_stops_at_once_with_one_line(tmp_path, argv, runs, judged):
    res = _fuzz(tmp_path, "--budget", "3s", *argv)
    assert res.returncode == 3, res.stdout + res.stderr
    err = _lines(res.stderr)
    assert len(err) == 1 and res.stdout == "", res.stdout + res.stderr
    assert err[0].startswith("buildhat-conformance fuzz: ")
    assert f"answers as {runs} (" in err[0] and f"judges it as {judged} (" in err[0], err[0]
    assert "unconfirmed" not in res.stderr and not (tmp_path / "junit.xml").exists()


def test_the_release_the_target_runs_is_accepted_when_named(tmp_path):
    res = _fuzz(tmp_path, "--budget", "1x", "--steps", "3", "--seed", "1", "-t", "inprocess:R2",
                "--firmware", "R2", "--quiet")
    assert res.returncode == 0, res.stdout + res.stderr


def test_a_target_that_takes_no_input_exits_3_with_one_line_why(tmp_path):
    """The emulator's firmware hangs after the host's third line: the prelude is never answered."""
    res = _fuzz(tmp_path, "--budget", "3s", "--quiet", "-t", "inprocess:R7?hang_after=3")
    assert res.returncode == 3, res.stdout + res.stderr
    err = _lines(res.stderr)
    assert len(err) == 1 and "no input was sent" in err[0], res.stderr
    assert " 0 inputs " in res.stdout and "not a finding" in res.stdout
    junit = ET.parse(tmp_path / "junit.xml").getroot()
    error = junit.find("testcase[@name='campaign']/error")
    assert junit.get("errors") == "1" and error is not None
    assert "no input was sent" in error.get("message", "")
    assert len([x for x in res.stdout.splitlines() if "could not start" in x]) == 1   # collapsed


def _finding(message: str):
    return finding_class("liveness")(message, [], {})


def _why(result: CampaignResult, stats: Stats) -> str:
    """``not_done``'s reason for a campaign that could not do its job (None would mean it did)."""
    why = not_done(result, stats)
    assert why is not None, "the campaign counts as done"
    return why


def test_not_done_names_no_input_sent_none_accepted_or_none_of_it():
    refused = CampaignResult(runs=4, prelude_failures=["target: no answer after the prelude"] * 4)
    assert _why(refused, Stats()).startswith("no input was sent: none of 4 run(s) got past the prelude")
    assert "budget ran out" in _why(CampaignResult(runs=1), Stats())
    stats = Stats(executions=12, answered=0)
    result = CampaignResult(runs=3, unconfirmed=[(_finding("no answer to the fence"), 3)])
    why = _why(result, stats)
    assert why.startswith("no input was accepted: 12 input(s) sent in 3 run(s)") and "no answer" in why
    assert not_done(CampaignResult(runs=3), Stats(executions=12, answered=5)) is None
    assert not_done(CampaignResult(runs=3, interrupted=True), Stats()) is None
    stopped = CampaignResult(runs=3, stopped="3 runs in a row could not start: x")
    assert "stopped answering" in _why(stopped, Stats(executions=12, answered=5))


def test_a_note_repeated_word_for_word_is_printed_once_and_counted():
    stream = io.StringIO()
    progress = Progress(Budget(seconds=3), 10, set(), True, stream=stream)
    for _ in range(5):
        progress.note("a [liveness] failure: replaying it 3 time(s) to confirm it")
    progress.note("something else")
    progress.end(Stats())
    lines = stream.getvalue().splitlines()
    assert lines.count("[fuzz] a [liveness] failure: replaying it 3 time(s) to confirm it") == 1
    assert "[fuzz] 5 times in all: a [liveness] failure: replaying it 3 time(s) to confirm it" in lines
    assert len(lines) == 3, lines


def test_identical_unconfirmed_failures_are_one_line_with_a_count(capsys):
    result = CampaignResult(runs=9, unconfirmed=[(_finding("no answer"), 3)] * 7 + [(_finding("other"), 3)])
    print_summary(result, Stats(executions=9, answered=9), ["help"], {}, "j.xml", 1, False, False, None)
    out = capsys.readouterr().out
    unconfirmed = [x for x in out.splitlines() if "unconfirmed" in x]
    assert len(unconfirmed) == 2 and "(x7)" in unconfirmed[0] and "no answer" in unconfirmed[0], out


def test_no_wire_share_for_an_unpaced_cmd_target(tmp_path):
    """A pipe to `buildhat-emulator --stdio` moves bytes as fast as they come: no 115200-baud share."""
    res = _fuzz(tmp_path, "--budget", "2x", "--steps", "4", "--quiet", "--seed", "2",
                "-t", f"cmd:{EMULATOR} --stdio")
    assert res.returncode in (0, 1), res.stdout + res.stderr
    assert res.stdout.startswith("fuzz: 2 runs") and "wire:" not in res.stdout, res.stdout


def test_reproduce_on_a_target_that_takes_no_prelude_is_not_a_reproduction(tmp_path):
    script = tmp_path / "liveness.script"
    script.write_text("@name fuzz finding (liveness): x\n> echo 0\n> version\n> vin\n> version\n",
                      encoding="utf-8")
    res = subprocess.run([EXE, "fuzz", "--reproduce", str(script), "-t", "inprocess:R7?hang_after=1",
                          "--confirm", "2"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 3, res.stdout + res.stderr
    assert res.stdout == "" and len(_lines(res.stderr)) == 1 and "did not take the prelude" in res.stderr
