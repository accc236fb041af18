"""The script runner and the ``script`` / ``targets`` sub-commands, on real stand-ins (a pty
responder, a ``cmd:`` child process)."""
from __future__ import annotations

import os
import sys
from typing import List, Tuple

import pytest
from harness_fakehat import HERE as FAKEHAT  # noqa: E402
from harness_fakehat import PtyResponder  # noqa: E402
from target_kinds import make_target_of

from buildhat_conformance.cli import main as cli
from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.harness.errors import NeedsCapability, TargetError
from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.transcript import read_transcript
from buildhat_conformance.transcripts.script import parse_script
from buildhat_conformance.transcripts.script_runner import Walk, check_capabilities, run_script, walk_actions

CMD = f"cmd:{sys.executable} -u {FAKEHAT} --stdio"

SCRIPT = """\
@name vin and list
;; a comment
> vin
@wait 30
>raw echo 1\\r
@wait 30
> list
@wait 10
"""


def test_run_script_sends_exact_bytes_and_writes_the_transcript(tmp_path):
    out = tmp_path / "run.jsonl"
    result = run_script(parse_script(SCRIPT, "vin.script"), make_target(CMD), transcript=str(out))
    assert result.ok, result.reason
    assert result.firmware.startswith("1737564117")
    t = read_transcript(str(out))
    assert t.meta["firmware"].startswith("1737564117") and t.meta["script"] == "vin.script"
    assert t.meta["name"] == "vin and list" and t.meta["profile"] == "R7"
    host = [e for e in t.of("host") if e["t"] >= 0]
    assert [e["bytes"] for e in host] == ["vin\r", "echo 1\r", "list\r"]
    # the first action is at the script's t = 0, the waits separate the rest (generous bounds)
    assert 0 <= host[0]["t"] < 1000 and host[1]["t"] - host[0]["t"] >= 29
    assert "7.20 V" in t.hat_lines()
    assert t.hat_lines().count("P0: no device detected") == 1
    assert any("partial" in e and e["partial"] == "P0>" for e in t.of("hat"))
    assert t.events[-1]["dir"] == "end" and t.events[-1]["t"] >= host[-1]["t"] + 10
    # the open's `version` exchange is kept, before t = 0
    assert any(e["t"] < 0 and e["bytes"] == "version\r" for e in t.of("host"))


def test_world_action_without_control_stops_before_sending_anything():
    responder = PtyResponder()
    try:
        script = parse_script("> vin\n@wait 10\n@plug 1 0x30\n> list\n")
        with pytest.raises(NeedsCapability, match="needs plug"):
            run_script(script, make_target(responder.path))
        assert responder.received == b""
    finally:
        responder.close()


def test_scripted_layout_needs_the_layout_capability():
    responder = PtyResponder()
    try:
        script = parse_script("@device 1 0x30\n> list\n")
        with pytest.raises(NeedsCapability, match="needs layout.*--layout-on-rig"):
            run_script(script, make_target(responder.path))
        assert responder.received == b""
        # the operator says the rig is wired so: `list` checks it (the stand-in has no devices)
        with pytest.raises(NeedsCapability, match=r"`list` shows P0 none, P1 none"):
            run_script(script, make_target(responder.path), layout_on_rig=True, layout_wait_s=0.3)
        assert b"list\r" in responder.received
    finally:
        responder.close()


def test_emulator_target_started_with_another_layout_is_refused():
    target = make_target("emulator?device=1=0x40")
    with pytest.raises(NeedsCapability, match="started with P0 0x30, P1 0x40"):
        check_capabilities(parse_script("@device 1 0x30\n> list\n"), target)
    # the same layout passes, and so does a script that uses world actions
    check_capabilities(parse_script("@device 1 0x40\n@plug 2 0x30\n"), target)


def test_target_dying_mid_script_ends_the_run_with_the_reason(tmp_path):
    out = tmp_path / "dead.jsonl"
    script = parse_script("> vin\n@wait 50\n> vin\n@wait 50\n> vin\n@wait 50\n")
    result = run_script(script, make_target(CMD + " --die-after 3"), transcript=str(out))
    assert not result.ok
    assert "exited with status 3" in result.reason and "line" in result.reason
    t = read_transcript(str(out))
    assert t.events[-1]["dir"] == "end" and "7.20 V" in t.hat_lines()


# -- the CLI ---------------------------------------------------------------------------------
def test_cli_script_runs_and_reports(tmp_path, capsys):
    path = tmp_path / "vin.script"
    path.write_text(SCRIPT)
    out = tmp_path / "out.jsonl"
    assert cli(["script", str(path), "--target", CMD, "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "vin and list: ran on cmd:" in text and f"transcript: {out}" in text
    assert read_transcript(str(out)).meta["name"] == "vin and list"


def test_cli_script_default_output_is_beside_the_script(tmp_path, monkeypatch):
    path = tmp_path / "s.script"
    path.write_text("> vin\n")
    monkeypatch.chdir(tmp_path)            # no reports/ here
    assert cli(["script", str(path), "--target", CMD, "-q"]) == 0
    written = [p for p in os.listdir(tmp_path) if p.endswith(".jsonl")]
    assert len(written) == 1 and written[0].startswith("s.cmd_")


def test_cli_script_exit_codes(tmp_path, capsys):
    bad = tmp_path / "bad.script"
    bad.write_text("> vin\n@wiat 10\n")
    assert cli(["script", str(bad), "--target", CMD]) == 2
    assert "bad.script:2: unknown world action @wiat" in capsys.readouterr().err
    assert cli(["script", str(tmp_path / "missing.script"), "--target", CMD]) == 2
    assert "no such script" in capsys.readouterr().err
    plug = tmp_path / "plug.script"
    plug.write_text("@plug 1 0x30\n")
    assert cli(["script", str(plug), "--target", CMD, "-o", str(tmp_path / "p.jsonl")]) == 3
    assert "skipped" in capsys.readouterr().err and not (tmp_path / "p.jsonl").exists()
    ok = tmp_path / "ok.script"
    ok.write_text("> vin\n")
    assert cli(["script", str(ok), "--target", "/dev/ttyNOSUCH", "-o", str(tmp_path / "n.jsonl")]) == 3
    assert "no such device: /dev/ttyNOSUCH" in capsys.readouterr().err
    silent = PtyResponder(mode="silent")
    try:
        assert cli(["script", str(ok), "--target", silent.path, "--open-timeout", "0.2",
                    "-o", str(tmp_path / "s.jsonl")]) == 3
        assert "nothing answering" in capsys.readouterr().err
    finally:
        silent.close()
    # the target answers the open's `version`, then exits; the script's wait gives the exit
    # a generous half second to be noticed
    dies = tmp_path / "dies.script"
    dies.write_text("> vin\n@wait 500\n> vin\n")
    out = str(tmp_path / "d.jsonl")
    assert cli(["script", str(dies), "--target", CMD + " --die-after 1", "-o", out]) == 3
    err = capsys.readouterr().err
    assert "exited with status 3" in err


def test_cli_targets_lists_ports_releases_and_urls(capsys, tmp_path, monkeypatch):
    assert cli(["targets"]) == 0
    out = capsys.readouterr().out
    assert "Serial ports:" in out and "emulator:R7" in out and "(latest, default)" in out
    assert "emulator:R1" in out and "1630165527" in out
    assert "cmd:<command line>" in out and "socket://HOST:PORT" in out
    r1 = next(line for line in out.splitlines() if "emulator:R1" in line)
    assert r1.count("1630165527") == 1, r1          # the version number once, then the build date
    assert "booted=1" in out and "baud=N" in out and "emulator:latest?speed=10" in out and "reset=gpio" in out


def test_run_script_on_a_virtual_time_target_keeps_exact_times(tmp_path):
    # The in-process emulator moves only when read: waits are spent in HAT time, exactly.
    text = "> version\n@wait 50\n@plug 3 0x30\n@wait 1500\n> list\n@wait 100\n"
    out = tmp_path / "v.jsonl"
    result = run_script(parse_script(text, "v.script"), make_target("inprocess:R7"), transcript=str(out))
    assert result.ok, result.reason
    t = read_transcript(str(out))
    assert [(e["t"], e["bytes"]) for e in t.of("host") if e["t"] >= 0] == [(0, "version\r"), (1550, "list\r")]
    assert [e["t"] for e in t.of("note") if e["text"].startswith("world @plug")] == [50]
    assert t.events[-1] == {"t": 1670, "dir": "end"}
    assert [e["t"] for e in t.of("hat") if e.get("line") == "P3: connecting to active device"][0] > 50


def test_a_layout_that_never_comes_up_is_reported(monkeypatch):
    # The target claims (its `layout`) to have been started with a P1 device that it was not:
    # the runner's `list` check catches it, within the HAT-time bound on a virtual-time target.
    target = make_target_of(InProcessTarget, "inprocess:R7")
    claimed = {0: ("active", 0x30), 1: ("active", 0x3E), 2: ("passive", 8), 3: None}
    monkeypatch.setattr(target, "layout", claimed, raising=False)
    with pytest.raises(TargetError, match=r"did not bring up the script's layout within 1 s: "
                                          r"`list` shows P0 0x30, P1 0x40"):
        run_script(parse_script("@device 1 0x3E\n> vin\n"), target, layout_wait_s=1.0)


# -- the one walk over a script's actions (emulator's --script mode walks with it too), with a driver
# that only logs: SCENARIO-SCRIPT.md's timing without any target in the way --------------------------

class LogDriver:
    """A clock that moves only when waited on, plus an optional fixed delay per action."""

    def __init__(self, delay_ms: float = 0.0, refuse: str = ""):
        self.t = 0.0
        self.delay_ms, self.refuse = delay_ms, refuse
        self.log: List[Tuple[float, str]] = []

    def now(self) -> float:
        return self.t

    def wait_until(self, t_ms: float) -> None:
        self.t = max(self.t, t_ms)

    def send(self, data: bytes) -> None:
        self.log.append((self.t, data.decode()))
        self.t += self.delay_ms

    def world(self, text: str) -> None:
        if text == self.refuse:
            raise RuntimeError("no such action")
        self.log.append((self.t, text))
        self.t += self.delay_ms


WALKED = parse_script("> vin\n@wait 30\n@plug 1 0x30\n@wait 12.5\n@wait 7\n> list\n@wait 100\n", "w.script")


def test_each_action_at_the_sum_of_the_waits_before_it_then_a_20_ms_tail():
    driver = LogDriver()
    walk = walk_actions(WALKED, driver)
    assert driver.log == [(0.0, "vin\r"), (30.0, "@plug 1 0x30"), (49.5, "list\r")]
    assert driver.t == 149.5 + 20
    assert walk.late_ms == 0 and walk.where == "after the last action"


def test_late_actions_do_not_push_the_later_ones_and_lateness_is_kept():
    driver = LogDriver(delay_ms=40)      # each action takes 40 ms: the plug goes out 10 ms late
    walk = walk_actions(WALKED, driver)
    assert [t for t, _ in driver.log] == [0.0, 40.0, 80.0]
    assert walk.late_ms == pytest.approx(30.5)


def test_end_ms_extends_the_run_and_a_failure_says_where():
    driver = LogDriver()
    walk_actions(WALKED, driver, end_ms=500)
    assert driver.t == 500
    walk = Walk()
    with pytest.raises(RuntimeError):
        walk_actions(WALKED, LogDriver(refuse="@plug 1 0x30"), walk=walk)
    assert walk.where == "at line 3 (@plug 1 0x30)"
    assert walk.action is not None and walk.action.lineno == 3
