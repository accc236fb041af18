"""Checking findings (fuzz/findings/confirm.py) within the campaign's bound, and what an interrupt leaves.

In-process targets with the planted `wrong` fault (tests/planted/faults.py: every `coast` also
prints `Error`): every run fails, every replay of it fails again, so only the bound, --confirm 0
or an interrupt can keep the checking short."""
from __future__ import annotations

import argparse
import pathlib
from typing import List

import pytest
from planted.faults import FAULTS

from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.fuzz import cli
from buildhat_conformance.fuzz.findings.confirm import Check, CheckClock, check_finding
from buildhat_conformance.fuzz.findings.shrink import steps_of
from buildhat_conformance.fuzz.running import from_arguments
from buildhat_conformance.fuzz.running.campaign import Campaign

EMPTY = {0: None, 1: None, 2: None, 3: None}


def _run(tmp_path: pathlib.Path, *extra: str, opens: List[int]):
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    args = parser.parse_args(["--target", "inprocess", "--profile", "R7", "--out", str(tmp_path / "out"),
                              "--no-database", "--quiet", "--budget", "3x", "--seed", "4", "--steps", "6",
                              "--families", "valid", "--waits", "", *extra])
    args.devices = EMPTY
    factory = FAULTS["wrong"]

    def opener():
        opens.append(1)
        return InProcessTarget("R7", devices=EMPTY, factory=factory)
    return from_arguments.run(args, primary=opener)


def test_confirm_0_replays_nothing_and_the_finding_says_it_was_not_checked(tmp_path):
    replayed: List[int] = []
    result, _ = _run(tmp_path / "a", "--confirm", "2", opens=replayed)
    assert result.findings[0].attempts == 2 and result.findings[0].cut is None
    opens: List[int] = []
    result, files = _run(tmp_path / "b", "--confirm", "0", opens=opens)
    finding = result.findings[0]
    assert (finding.reproduced, finding.attempts) == (0, 0)
    assert finding.cut == "not replayed (--confirm 0): neither confirmed nor reduced"
    # One open for the release check, one per run: no replay (with --confirm 2 there were more).
    assert len(opens) == 1 + result.runs < len(replayed)
    script = pathlib.Path(files["fate"]["script"]).read_text(encoding="utf-8")
    assert ";; reproduced: not replayed" in script and ";; checking cut short: not replayed" in script


def test_checking_stops_at_its_bound_and_the_summary_line_says_so(tmp_path, capsys):
    opens: List[int] = []
    result, _ = _run(tmp_path, "--confirm", "100000", "--check-time", "1", opens=opens)
    finding = result.findings[0]
    assert 0 < finding.attempts < 100000 and finding.reproduced == finding.attempts
    assert finding.cut == (f"{finding.attempts} of 100000 replays ran, not reduced: the checking time "
                           "(--check-time 1s) ran out")
    assert result.check_cut == 1
    assert result.checking < 30          # 100000 replays unbounded would take many minutes
    out = capsys.readouterr().out
    assert ("confirming findings, cut short at its bound, --check-time 1s: 1 finding(s) not fully "
            "checked") in out
    assert "checking cut short: " in out


@pytest.mark.parametrize("stop_at, cut", [
    (1, "not confirmed: interrupted before its first replay"),
    (3, "interrupted while it was being checked (2 of 2 replays failed again)"),
])
def test_ctrl_c_while_confirming_keeps_the_finding_as_far_as_it_was_checked(tmp_path, monkeypatch, stop_at,
                                                                           cut):
    calls: List[int] = []
    replay = Campaign.replay

    def interrupted(self, script):
        calls.append(1)
        if len(calls) == stop_at:
            raise KeyboardInterrupt
        return replay(self, script)
    monkeypatch.setattr(Campaign, "replay", interrupted)
    result, files = _run(tmp_path, "--confirm", "5", opens=[])
    assert result.interrupted and len(result.findings) == 1
    assert result.findings[0].cut == cut
    assert pathlib.Path(files["fate"]["target"]).exists()


def test_an_interrupt_while_reducing_keeps_the_smallest_failing_script_so_far(tmp_path):
    result, _ = _run(tmp_path, "--confirm", "0", opens=[])
    found = result.findings[0].finding
    check = Check(found, seed=1)
    calls: List[int] = []

    def replay(_script):                  # every replay fails the same way, the 4th is interrupted
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return found
    with pytest.raises(KeyboardInterrupt):
        check_finding(check, replay, 1, 30.0, CheckClock(None).deadline(), "", lambda _text: None)
    kept = check.result(check.interrupted())
    assert kept is not None and check.smaller is not None
    assert kept.cut == "interrupted while it was being reduced: the smallest failing script found so far"
    assert len(steps_of(kept.script)) < len(steps_of(check.script))
