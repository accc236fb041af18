"""Fuzz campaigns: clean against the emulator, and a shrunk, replayable finding for each planted fault.

Planted faults (tests/planted/faults.py) wrap the real emulator; a finding counts only if its
written script replays to the same oracle failure on a fresh target.
"""
from __future__ import annotations

import argparse
import pathlib
import xml.etree.ElementTree as ET

import pytest
from planted.faults import FAULTS
from repo_paths import TESTS

from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.fuzz import cli
from buildhat_conformance.fuzz.findings.replay import replay_script
from buildhat_conformance.fuzz.findings.shrink import steps_of
from buildhat_conformance.fuzz.running import from_arguments
from buildhat_conformance.protocol.profiles import get_profile
from buildhat_conformance.transcripts.script import load_script

HERE = TESTS
# A motor on port 0 (reports, drive), nothing else: the cheapest layout that has every behaviour.
LAYOUT = {0: ("active", 0x30), 1: None, 2: None, 3: None}
EMPTY = {0: None, 1: None, 2: None, 3: None}   # the planted faults are in the command port


def _args(out: pathlib.Path, *extra: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    args = parser.parse_args(["--target", "inprocess", "--profile", "R7", "--out", str(out), "--no-database",
                              "--quiet", *extra])
    args.devices = LAYOUT
    return args


def _opener(factory=None, devices=None):
    return lambda: InProcessTarget("R7", devices=LAYOUT if devices is None else devices, factory=factory)


def test_short_campaign_against_the_emulator_has_no_findings(tmp_path):
    args = _args(tmp_path, "--budget", "12x", "--seed", "7", "--steps", "15")
    result, files = from_arguments.run(args, primary=_opener())
    assert not result.findings, "\n".join(f"{f.oracle}: {f.finding.message}" for f in result.findings)
    junit = ET.parse(tmp_path / "junit.xml").getroot()
    names = {c.get("name") for c in junit.iter("testcase")}
    assert names == {"liveness", "fate", "state", "hygiene"}
    assert junit.get("failures") == "0"


@pytest.mark.parametrize("kind,oracles,trigger", [
    ("hang", {"liveness"}, b"l"),
    ("wrong", {"fate", "state"}, b"co"),        # an extra Error line: where the prompt was due, too
    ("drop", {"fate", "state", "hygiene", "liveness"}, None),
])
def test_planted_fault_gives_a_shrunk_replayable_finding(tmp_path, kind, oracles, trigger):
    factory = FAULTS[kind]
    args = _args(tmp_path, "--budget", "60x", "--seed", "3", "--families", "valid", "--steps", "8",
                 "--shrink-time", "60", "--waits", "")
    args.devices = EMPTY
    result, files = from_arguments.run(args, primary=_opener(factory, EMPTY))
    assert result.findings, f"the planted '{kind}' fault was not found"
    finding = result.findings[0]
    assert finding.oracle in oracles, finding.finding.message
    script = load_script(files[finding.oracle]["script"])        # the scenario-script format
    steps = steps_of(script)
    # Shrunk: the prelude, the failing step and at most one step that sets the scene (echo on).
    assert len(steps) <= 3, f"not shrunk: {[a.text for a in script.actions]}"
    if trigger is not None:
        sent = [a.data for a in steps[-1]]
        assert sent[0].startswith(trigger), sent
    # Replays to the same failure on a fresh target with the fault ...
    again = replay_script(script, _opener(factory, EMPTY), get_profile("R7"), fence_s=0.3)
    assert again is not None and again.oracle == finding.oracle
    # ... and passes on the emulator without it: the finding is the fault's, not the fuzzer's.
    assert replay_script(script, _opener(None, EMPTY), get_profile("R7"), fence_s=0.3) is None
    assert files, "a finding writes its files"
    junit = ET.parse(tmp_path / "junit.xml").getroot()
    failed = {c.get("name") for c in junit.iter("testcase") if c.find("failure") is not None}
    assert finding.oracle in failed and failed <= oracles
    assert (tmp_path / f"{finding.oracle}.target.jsonl").exists()


def test_planted_fault_behind_a_cmd_proxy_replays_as_the_same_finding(tmp_path):
    """The same fault as a byte proxy around `buildhat-emulator --stdio` (a `cmd:` target)."""
    import sys

    from buildhat_conformance.fuzz.running.checked_run import PRELUDE
    from buildhat_conformance.harness.targets import make_target
    lines = [f"> {line.decode()}" for line in PRELUDE.split(b"\r") if line]
    lines += ["> version", "> co", "> version"]
    path = tmp_path / "wrong.script"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    url = (f"cmd:{sys.executable} {HERE / 'planted' / 'proxy.py'} wrong "
           "--device 0=none --device 1=none --device 2=none --device 3=none")
    finding = replay_script(str(path), lambda: make_target(url), get_profile("R7"), fence_s=2.0, fresh=True)
    assert finding is not None and finding.oracle == "fate", finding and finding.message
    assert b"Error" in finding.details["received"]


def _oracle_after(fault, line: bytes, wait_ms: int):
    """The oracle that fails when ``line`` is sent and ``wait_ms`` pass (None: no finding),
    against the emulator with ``fault`` planted (None: as it is)."""
    from buildhat_conformance.fuzz.oracles.registry import Finding
    from buildhat_conformance.fuzz.running.checked_run import Runner
    factory = FAULTS[fault] if fault else None
    runner = Runner([("target", _opener(factory), get_profile("R7"))], 0.3, True, devices=LAYOUT)
    try:
        runner.start()
        runner.exchange([line])
        runner.wait(wait_ms)
        return None
    except Finding as exc:
        return exc.oracle
    finally:
        runner.close()


@pytest.mark.parametrize("fault,finding", [(None, None), ("mute", "state")])
def test_state_oracle_expects_reports_from_a_selected_mode(fault, finding):
    """`select 1` on the motor must report within a 400 ms wait; a HAT that stays silent fails."""
    assert _oracle_after(fault, b"select 1\r", 400) == finding


@pytest.mark.parametrize("fault,finding", [(None, None), ("combiform", "state")])
def test_state_oracle_checks_the_form_of_a_combi_report(fault, finding):
    """After `combi 0 ...` and `select 0` the HAT prints `P0C0:` (§6.1); one that prints `P0M0:`
    fails, though the combi command reached the device (the form is the HAT's, not the device's)."""
    assert _oracle_after(fault, b"combi 0 1 0 2 0 3 0\rselect 0\r", 400) == finding


@pytest.mark.parametrize("fault,finding", [(None, None), ("plimit", "state")])
def test_state_oracle_checks_the_drive_against_plimit(fault, finding):
    """`set 0.5` in direct PWM mode drives 0.1 * 255 (the default plimit, §7.3): 25, not more."""
    assert _oracle_after(fault, b"set 0.5\r", 50) == finding


def test_a_report_due_before_a_selonce_does_not_end_that_selonce():
    """A report of the old selection printed while a step's input is still arriving (a paced
    wire: here a long comment line) belongs to that selection; the `selonce 2` after it still
    has its own once-report to come (§6.2). The model once took the `P0V:` report for it and
    called the real `P0M2:` report that followed a state finding (issue 14)."""
    from buildhat_conformance.fuzz.running.checked_run import Runner
    profile = get_profile("R7")
    target = InProcessTarget("R7", devices=LAYOUT, baud=115200)
    runner = Runner([("target", lambda: target, profile)], 0.3, True, devices=LAYOUT)
    try:
        runner.start()
        runner.exchange([b"select 0 0 u1\r", b"selrate 0\r"])     # a V report for every message
        answer = runner.exchange([b"#" + b" " * 250 + b"\r", b"selonce 2\r"])[0]
        assert answer.startswith(b"P0V: "), answer     # the scene: the old selection reported
        runner.wait(100)                                # P0M2 comes: no finding
        assert runner.sides[0].model.ports[0].rate == -2   # and the once is over
    finally:
        runner.close()


def test_a_combi_set_while_a_device_connects_may_outlive_the_setup():
    """`combi 0 ...` sent while a motor plugged into port 2 is still in its setup phase: the
    facts say a reconnect clears the table, not whether an entry set during the setup survives
    (§8), and this emulator keeps it. A `P2C0:` report after `select 0` is then no state finding
    (the model once took `established` for an empty table and wanted `P2M0:`)."""
    from buildhat_conformance.fuzz.running.checked_run import Runner
    profile = get_profile("R7")
    target = InProcessTarget("R7", devices=LAYOUT)
    runner = Runner([("target", lambda: target, profile)], 0.3, True, devices=LAYOUT)
    try:
        runner.start()
        target.control.action("@plug 2 0x30")
        runner.wait(150)                                # "P2: connecting to active device"
        runner.exchange([b"port 2\r", b"combi 0 1 0 2 0 3 0\r"])
        runner.wait(3000)                               # ... "established ... ID 30"
        assert runner.sides[0].model.ports[2].device_modes > 0, "the motor did not connect"
        runner.exchange([b"select 0\r"])
        runner.wait(400)
    finally:
        runner.close()


def test_kept_targets_that_took_a_set_up_in_part_are_started_anew():
    """fuzz/oracles/setup_loss.py: such a port is not compared until its device sets up again, which on a kept
    HAT may be never (a sil campaign left 444 steps' port 0 uncompared); new HATs compare it again."""
    from buildhat_conformance.fuzz.oracles.setup_loss import for_target
    from buildhat_conformance.fuzz.running.campaign import Campaign, _Keeper
    from buildhat_conformance.harness.events import classify

    class _Target:
        closed = False

        def close(self) -> None:
            self.closed = True

    campaign = Campaign.__new__(Campaign)
    campaign.keepers = [_Keeper(_Target, True), _Keeper(_Target, True)]   # type: ignore[arg-type]
    campaign.against = (campaign.keepers[1], get_profile("R7"))
    first, second = campaign.keepers[0](), campaign.keepers[1]()
    for k in campaign.keepers:
        k.clean = True
    assert not campaign._set_up_in_part()
    for_target(second).feed([classify(b"P2: connecting to active device"), classify(b"MQ overrun!")])
    assert campaign._set_up_in_part()
    campaign.discard_targets()
    assert first.closed and second.closed           # type: ignore[attr-defined]
    assert all(k.target is None and not k.clean for k in campaign.keepers)
    assert not campaign._set_up_in_part()


def test_a_run_on_a_kept_target_does_not_take_the_layout_for_granted():
    """The sil `state` finding of issue 22 (60 sightings, never confirmed): an earlier run on a kept-open
    HAT left the light matrix without motor power (`coast`), so it stopped talking for good and the port
    reset drives it 0 (docs/FIRMWARE-BEHAVIOUR.md#fb-pwm-path: no device connected, drive 0). A later run's
    model was built from the layout anyway and judged port 1's drive as if the matrix were there:
    `port 1 drives 0; ... should drive 'coast'`. Only a run on a newly opened target knows the layout."""
    from buildhat_conformance.fuzz.oracles.registry import Finding
    from buildhat_conformance.fuzz.running.campaign import Campaign, CampaignConfig
    from buildhat_conformance.protocol.devices import DEFAULT_LAYOUT

    layout = dict(DEFAULT_LAYOUT)                       # the light matrix on port 1
    config = CampaignConfig(open_primary=lambda: InProcessTarget("R7", devices=layout),
                            profile=get_profile("R7"), keep_open=True, devices=layout)
    campaign = Campaign(config)
    runner = campaign._runner()
    assert runner.fresh and runner.sides[0].model.ports[1].device_modes > 0   # a new HAT: the layout holds
    runner.start()
    runner.exchange([b"port 1 ; coast\r"])
    for _ in range(8):                                  # past the matrix's grace and the HAT's timeout
        runner.wait(300)
    runner.close()
    runner = campaign._runner()                         # the same HAT, its matrix gone
    runner.settled = True
    assert not runner.fresh
    try:
        runner.start()
        runner.exchange([b"port 1 ; on ; coast\r"])
        runner.wait(60)
    except Finding as finding:
        pytest.fail(finding.message)
    finally:
        runner.close()
    campaign.discard_targets()
    runner = campaign._runner()                         # opened anew: the layout holds again
    assert runner.fresh and runner.sides[0].model.ports[1].device_modes > 0
    runner.close()
