"""Runs on a target kept open from run to run (the pty and paced campaigns, issue 14).

The prelude resets echo, debug, the port and the selections, but not a port's combi table:
nothing but a new connection clears it (FIRMWARE-FACTS §6.1, §6.2). A run that follows another
on the same HAT must not assume that the table is empty. All in virtual time (in-process).
"""
from __future__ import annotations

from typing import Dict, List, Optional

import pytest
from planted.faults import FAULTS

from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.fuzz.oracles.registry import Finding
from buildhat_conformance.fuzz.running.checked_run import Runner
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


def _second_run(factory, first: List[bytes], second: List[bytes], unplug: Optional[int] = None,
                wait_ms: int = 400) -> tuple:
    """As :func:`_runs`, on a target made by ``factory`` (a planted fault), perhaps with a device
    unplugged between the runs; (the second run's finding or None, its model's device modes)."""
    profile = get_profile("R7")
    target = InProcessTarget("R7", devices=LAYOUT, factory=factory)
    target.open()
    modes: List[int] = []
    try:
        runner = Runner([("target", lambda: target, profile)], 0.3, True, devices=LAYOUT, keep_open=True)
        runner.start()
        runner.exchange(first)
        runner.close()
        if unplug is not None:
            target.control.action(f"@unplug {unplug}")   # the world action, as a script's
            target.advance(2000)                          # (the HAT notices it gone)
        runner = Runner([("target", lambda: target, profile)], 0.3, False, keep_open=True)
        try:
            runner.start()
            modes = [p.device_modes for p in runner.sides[0].model.ports]
            runner.exchange(second)
            runner.wait(wait_ms)
        except Finding as finding:
            return finding, modes
        finally:
            runner.close()
    finally:
        target.close()
    return None, modes


def test_a_later_run_knows_the_devices_its_prelude_lists():
    """A run on a HAT an earlier run left open takes no layout for granted (a device may have
    gone: the sil finding of `--seed 22`), but its prelude's `list` names the devices that are
    there, so the drive and report checks judge them from its first step. Before, they waited for
    an `established` line, which a device that stays never prints again: a wrong drive passed."""
    from planted.faults import IgnoresPlimit

    # (what an earlier run may have left, and the prelude does not reset, is set again first)
    step = [b"plimit 0.1\r", b"port 0\r", b"pwm\r", b"pwmparams 0 0\r", b"set 0.5\r"]
    finding, modes = _second_run(None, [b"vin\r"], step)
    assert finding is None, finding.message
    assert modes[0] > 0 and modes[1:] == [0, 0, 0], modes          # the motor; nothing elsewhere
    finding, _modes = _second_run(IgnoresPlimit, [b"vin\r"], step)
    assert finding is not None and finding.oracle == "state", finding
    assert "port 0 drives" in finding.message, finding.message


def test_a_device_gone_since_the_last_run_is_not_taken_for_there():
    finding, modes = _second_run(None, [b"vin\r"], [b"port 0\r", b"pwm\r", b"set 0.5\r"], unplug=0)
    assert finding is None, finding.message
    assert modes == [0, 0, 0, 0], modes


_LEFT = {   # a drive setting run 1 leaves on port 0, and run 2's step, which sets every other one
    "plimit": (b"plimit 1\r", [b"port 0\r", b"pwm\r", b"pwmparams 0 0\r", b"set 0.3\r"]),
    "pwmparams": (b"pwmparams 0.5 0.2\r", [b"plimit 1\r", b"port 0\r", b"pwm\r", b"set 0.3\r"]),
    "pid": (b"pid 0 0 0 s1 1 0 3 0 0 0 0\r", [b"plimit 1\r", b"port 0\r", b"pwmparams 0 0\r", b"set 0.3\r"]),
}


@pytest.mark.parametrize("left", sorted(_LEFT))
def test_drive_settings_an_earlier_run_left_are_not_taken_for_defaults(left):
    """The `state` finding of the 10-minute campaign once the prelude's `list` let the drive check
    judge later runs (`--seed 22`, reproduced 3/3 on the kept target, 0/3 on new ones): `port 0
    drives 1` where `on` at full plimit should drive 255. The prelude resets no drive setting, and
    the model took the defaults. An earlier run's plimit, pwmparams or controller mode now leaves
    the duty unjudged until this run sets it (run 2 sets every other one)."""
    setting, again = _LEFT[left]
    finding, _modes = _second_run(None, [b"port 0\r", setting], again)
    assert finding is None, finding.message


def test_a_reconnect_puts_the_drive_settings_back_to_their_defaults():
    """FIRMWARE-BEHAVIOUR fb-port-reset: a disconnect resets the port's controller, its bias or
    pwmparams and (R6+) its limit to 0.1. A run that set `plimit 1`, then saw its motor go and come
    back, judges `set 0.5` at the default limit (25), not the one it set (127)."""
    profile = get_profile("R7")
    target = InProcessTarget("R7", devices=LAYOUT)
    runner = Runner([("target", lambda: target, profile)], 0.3, True, devices=LAYOUT)
    try:
        runner.start()
        runner.exchange([b"plimit 1\r", b"port 0\r", b"pwm\r"])
        target.control.action("@unplug 0")
        runner.wait(600)                                    # "P0: disconnected"
        target.control.action("@plug 0 0x30")
        runner.wait(3000)                                   # ... "established ... ID 30"
        assert runner.sides[0].model.ports[0].device_modes > 0, "the motor did not connect again"
        runner.exchange([b"port 0\r", b"set 0.5\r"])
        runner.wait(200)
    except Finding as finding:
        pytest.fail(finding.message)
    finally:
        runner.close()
