"""The served HAT's record of motor-drive changes (serving/drive_log.py) and its control request,
``@drive_events SINCE`` (serving/control_channel.py), in virtual time: what the conformance cases that
look at the drive read on a served target (``emulator``, ``sil:TREE?speed=N``)."""
from __future__ import annotations

import json

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.serving.control_channel import ControlHandler
from buildhat_conformance.serving.drive_log import DriveLog, FrameLog


def pwm(t: int, port: int, value: object) -> dict:
    return {"t": t, "dir": "pwm", "port": port, "value": value}


def test_since_gives_each_ports_level_at_the_start_then_the_changes():
    log = DriveLog()
    for event in (pwm(10, 0, 5), pwm(20, 1, 7), pwm(30, 0, 9), {"t": 35, "dir": "dev", "port": 0},
                  {"t": 40, "dir": "led", "value": 2}, pwm(50, 0, "coast")):
        log.record(event)
    got = log.since(30)
    assert got[:2] == [pwm(20, 1, 7), pwm(30, 0, 9)]            # levels at t=30, oldest first
    assert got[2:] == [{"t": 40, "dir": "led", "value": 2}, pwm(50, 0, "coast")]
    assert log.since(0) == [pwm(10, 0, 5), pwm(20, 1, 7), pwm(30, 0, 9),
                            {"t": 40, "dir": "led", "value": 2}, pwm(50, 0, "coast")]
    assert all(e["dir"] != "dev" for e in log.since(0))        # only drive changes are kept


def test_a_full_log_still_knows_the_level_of_a_port_that_changed_long_ago():
    log = DriveLog(limit=3)
    log.record(pwm(1, 2, 40))                  # port 2, then only port 0 for a long time
    for t in range(10, 100, 10):
        log.record(pwm(t, 0, t))
    assert len(log.recent) == 3
    assert log.since(75) == [pwm(1, 2, 40), pwm(70, 0, 70), pwm(80, 0, 80), pwm(90, 0, 90)]


def test_control_request_matches_what_the_emulator_recorded():
    emu = Emulator(firmware="R7")
    handler = ControlHandler(emu)
    emu.boot()
    start = emu.now
    emu.write(b"port 0 ; pwm ; plimit 1 ; set 0.5\r")
    emu.advance(50)
    emu.write(b"coast\r")
    emu.advance(50)
    reply = handler(f"@drive_events {start}")
    assert reply.startswith("ok [") and "\n" not in reply
    served = json.loads(reply[3:])
    recorded = [e for e in emu.events if e["dir"] == "pwm" and e["t"] > start]
    assert recorded and [e for e in served if e["t"] > start] == recorded
    assert [e["value"] for e in served if e.get("port") == 0 and e["t"] > start][-1] == "coast"
    handler("@reset")                           # the record goes on over a power cycle
    emu.advance(2000)
    assert handler(f"@drive_events {emu.now}").startswith("ok [")
    for bad in ("@drive_events", "@drive_events x", "@drive_events 1 2"):
        assert handler(bad).startswith("error @drive_events takes")


def test_device_frames_request_gives_the_frames_a_device_received():
    # `@device_frames SINCE` (serving/drive_log.py's FrameLog): what frames_to_device reads on a
    # served target; the frame is FIRMWARE-BEHAVIOUR#fb-write's example.
    emu = Emulator(firmware="R7")
    handler = ControlHandler(emu)
    emu.boot()
    start = emu.now
    emu.write(b"port 0 ; write1 c5 10 20 30 40\r")
    emu.advance(50)
    served = json.loads(handler(f"@device_frames {start}")[3:])
    assert {"D5 10 20 30 40 6A"} <= {e["hex"] for e in served if e["port"] == 0}
    assert all(e["dir"] == "dev" and e["t"] >= start for e in served)
    assert handler(f"@device_frames {emu.now + 1}") == "ok []"
    for bad in ("@device_frames", "@device_frames x"):
        assert handler(bad).startswith("error @device_frames takes")
    log = FrameLog(limit=2)
    for t in (1, 2, 3):
        log.record({"t": t, "dir": "dev", "port": 0, "hex": "02"})
    log.record(pwm(4, 0, 5))
    assert [e["t"] for e in log.since(0)] == [2, 3]          # the newest only, frames only
