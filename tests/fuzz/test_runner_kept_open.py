"""Runs on a target kept open from run to run (the pty and paced campaigns, issue 14).

The prelude resets echo, debug, the port and the selections, but not a port's combi table:
nothing but a new connection clears it (FIRMWARE-FACTS §6.1, §6.2). A run that follows another
on the same HAT must not assume that the table is empty. All in virtual time (in-process).
"""
from __future__ import annotations

from typing import Dict, List, Optional

import pytest
from planted.faults import FAULTS

from buildhat_conformance.emulator.inprocess_target import InProcessTarget
from buildhat_conformance.fuzz.oracles import Finding
from buildhat_conformance.fuzz.runner import Runner
from buildhat_conformance.protocol.profiles import get_profile

LAYOUT = {0: ("active", 0x30), 1: None, 2: None, 3: None}    # a motor on port 0


def _runs(first: List[bytes], second: List[bytes], wait_ms: int = 400) -> Optional[Finding]:
    """``first`` as one clean run, then ``second`` and a wait as the next run on the same open
    target, as a campaign does (the second run does not know what the first left). Returns the
    second run's finding, if any."""
    profile = get_profile("R7")
    target = InProcessTarget("R7", devices=LAYOUT)
    target.open()
    try:
        runner = Runner([("target", lambda: target, profile)], 0.3, True, devices=LAYOUT, keep_open=True)
        runner.start()
        runner.exchange(first)
        runner.close()
        runner = Runner([("target", lambda: target, profile)], 0.3, False, keep_open=True)
        runner.settled = True           # the first run ended cleanly: no drain, no sync
        try:
            runner.start()
            runner.exchange(second)
            runner.wait(wait_ms)
        except Finding as finding:
            return finding
        finally:
            runner.close()
    finally:
        target.close()
    return None


@pytest.mark.parametrize("select", [b"select 0\r", b"selonce 0\r"])
def test_a_combi_left_by_an_earlier_run_may_shape_the_reports(select):
    """The state finding of issue 14: run 1 configured combi 0 on the motor; run 2 selects mode 0
    and the HAT, rightly, reports `P0C0: ...` (the table survived the prelude)."""
    finding = _runs([b"combi 0 1 0 2 0 3 0\r"], [select])
    assert finding is None, finding.message


def test_a_combi_the_run_cleared_is_known_again():
    """`combi 0` with no pairs empties the entry: run 2 knows mode 0 reports as `M0` again, and
    still expects that report (the oracle is not switched off by what run 1 left)."""
    finding = _runs([b"combi 0 1 0 2 0 3 0\r"], [b"combi 0\r", b"select 0\r"])
    assert finding is None, finding.message


@pytest.mark.parametrize("fresh", [True, False])
def test_a_finding_says_whether_its_run_began_on_a_fresh_target(fresh):
    """The finding's script and summary say when the run began on a HAT earlier runs had left,
    where a fresh `fuzz --reproduce` may not reproduce it (fuzz/cli.py reads this flag)."""
    empty: Dict[int, Optional[tuple]] = {0: None, 1: None, 2: None, 3: None}
    target = InProcessTarget("R7", devices=empty, factory=FAULTS["wrong"])
    runner = Runner([("target", lambda: target, get_profile("R7"))], 0.3, fresh, devices=empty)
    with pytest.raises(Finding) as caught:
        runner.start()
        runner.exchange([b"co\r"])          # the planted fault: `coast` answers Error
    runner.close()
    assert caught.value.details["fresh"] is fresh
