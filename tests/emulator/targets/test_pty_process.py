"""The ``emulator`` target end to end with the real ``buildhat-emulator`` process: start-up on
a pty, version detection, world actions over the control socket, failure and death."""
from __future__ import annotations

import os
import signal

import pytest
from target_kinds import make_target_of

from buildhat_conformance.emulator.targets.pty_process import EmulatorTarget
from buildhat_conformance.harness.errors import TargetError
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.transcript import read_transcript
from buildhat_conformance.protocol.profiles import get_profile
from buildhat_conformance.transcripts.script import parse_script
from buildhat_conformance.transcripts.script_runner import run_script


def test_emulator_open_detect_and_world_actions():
    target = make_target_of(EmulatorTarget, "emulator:R5?speed=5&device=1=none&device=2=none")
    with Session(target) as s:
        assert s.profile == get_profile("R5") and s.profile_exact and not s.in_bootloader
        assert s.time_scale == 5.0
        assert [e.kind for e in s.command("vin")][-1] == "vin"
        s.expect(lambda e: e.kind == "established" and e.port == 0, 20)
        assert s.world("@unplug 0") == ""
        assert s.expect("disconnected", 20).port == 0
        s.world("@plug 0 0x30")
        assert s.expect("established", 20).fields == {"port": 0, "id": 0x30}
        assert int(target.control.request("@time")) > 0
        with pytest.raises(TargetError, match="emulator refused '@plug 9 0x30'"):
            s.world("@plug 9 0x30")
        assert target.child is not None and target.child.pid is not None
        pid = target.child.pid
    with pytest.raises(ProcessLookupError):
        os.killpg(pid, 0)   # close() ended the emulator's whole process group


def test_booted_emulator_starts_with_its_devices_up():
    """`?booted=1`: as a HAT powered up before the host opened the port. The start-up ran
    already (its banner reached nobody) and `list` shows the layout at once, where a cold
    start needs about a second of device set-up at real time (FACTS §5)."""
    target = make_target("emulator:R7?booted=1&device=3=0x3D")
    with Session(target) as s:
        assert b"Type help" not in bytes(s.received)
        assert target.control.action("@settled").strip().endswith("1")
        lines = [e.text for e in s.command("list")]
        for line in ("P0: connected to active ID 30", "P1: connected to active ID 40",
                     "P2: connected to passive ID 8", "P3: connected to active ID 3D"):
            assert line in lines


def test_served_emulator_shows_the_motor_drive():
    """The drive a port puts out comes over the control channel (``@drive_events``), as the
    in-process targets' ``drive_events``: with plimit 1, direct PWM at 0.4 drives 0.4 x 255 = 102
    (docs/FIRMWARE-BEHAVIOUR.md#fb-pwm-path), and a coasting port coasts."""
    target = make_target_of(EmulatorTarget, "emulator:R7?booted=1&speed=5")
    with Session(target) as s:
        assert target.has("drive_events")
        start = target.now
        s.command("port 0 ; pwm ; plimit 1 ; set 0.4")
        s.wait_ms(100)
        drive = [e["value"] for e in target.drive_events_since(start) if e.get("port") == 0]
        assert drive[-1] == 102, drive
        s.command("coast")
        s.wait_ms(100)
        drive = [e["value"] for e in target.drive_events_since(target.now) if e.get("port") == 0]
        assert drive[-1] == "coast", drive


def test_booted_and_bootloader_exclude_each_other():
    with pytest.raises(TargetError, match="booted"):
        make_target("emulator:?booted=1&bootloader=1")


def test_emulator_failing_to_start_carries_its_error():
    with pytest.raises(TargetError) as info:
        make_target("emulator:R99").open()
    msg = str(info.value)
    assert "the emulator failed to start" in msg and "exit status 2" in msg
    assert "unknown firmware 'R99'" in msg       # the emulator's own words, from its stderr


def test_emulator_dying_mid_session_is_reported():
    target = make_target_of(EmulatorTarget, "emulator?speed=5")
    s = Session(target).open()
    try:
        assert target.child is not None and target.child.pid is not None
        os.killpg(target.child.pid, signal.SIGKILL)
        with pytest.raises(TargetError, match="the emulator went away"):
            s.expect("error", 20)
    finally:
        s.close()


def test_script_on_the_emulator_gets_the_scripted_layout(tmp_path):
    text = "@name layout\n@device 1 0x30\n@device 2 none\n> list\n@wait 100\n"
    script = parse_script(text, "layout.script")
    out = tmp_path / "layout.jsonl"
    result = run_script(script, make_target("emulator?speed=5", devices=dict(script.explicit_devices)),
                        transcript=str(out))
    assert result.ok, result.reason
    t = read_transcript(str(out))
    # meta.devices as the emulator's script mode writes it (TRANSCRIPT.md), so replay reads it back
    assert t.meta["devices"] == {"0": "0x30", "1": "0x30", "2": "none", "3": "none"}
    assert t.meta["profile"] == "R7"
    after = [e["line"] for e in t.of("hat") if "line" in e and e["t"] >= 0]
    assert "P1: connected to active ID 30" in after and "P2: no device detected" in after
    assert "P3: no device detected" in after


def test_emulator_in_its_bootloader_is_detected():
    with Session(make_target("emulator?bootloader=1")) as s:
        assert s.in_bootloader and s.profile is None
        assert s.version_string.startswith("1737564075")
        assert [e.kind for e in s.command("clear")] == ["echo", "bootloader_prompt"]


def test_reset_into_the_bootloader_and_back():
    with Session(make_target("emulator?speed=5")) as s:
        assert not s.in_bootloader
        s.reset(bootloader=True)
        assert s.in_bootloader and s.profile is None
        restart = s.reset()
        assert not s.in_bootloader and s.profile == get_profile("R7")
        assert any(e.kind == "banner" for e in restart)
