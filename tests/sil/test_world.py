"""The firmware in the loop's world skips a motor's samples while what it shows cannot change
(sil/world.py): the modes it counts as reading the shaft must be exactly those whose values do."""
from __future__ import annotations

import random

from buildhat_conformance.emulator.devices import MotorDevice, make_device
from buildhat_conformance.protocol.devices import parse_device_spec
from buildhat_conformance.sil.world import SHAFT_MODES, SilWorld, shows_shaft


def _motor() -> MotorDevice:
    dev = make_device(parse_device_spec("0x30"), random.Random(1))
    assert isinstance(dev, MotorDevice)
    return dev


def test_the_shaft_modes_are_the_modes_whose_values_move_with_the_shaft():
    dev = _motor()
    before = {m: dev.model_values(m, 0) for m in dev.modes}
    dev.physics.step(500, 255)                    # half a second at full drive: the shaft turns
    moved = {dev.modes[m]["name"] for m in dev.modes if dev.model_values(m, 500) != before[m]}
    shown = {dev.modes[m]["name"] for m in dev.modes} & SHAFT_MODES
    assert moved == shown == SHAFT_MODES, (moved, shown)


def test_a_combi_with_a_shaft_mode_shows_the_shaft():
    dev = _motor()
    by_name = {m["name"]: i for i, m in dev.modes.items()}
    dev.mode = by_name["POWER"] if "POWER" in by_name else min(i for i, m in dev.modes.items()
                                                              if m["name"] not in SHAFT_MODES)
    assert not shows_shaft(dev)
    dev.combis[dev.mode] = [(by_name["POS"], 0)]
    assert shows_shaft(dev)


def test_a_world_action_steps_the_shafts_up_to_it_first():
    world = SilWorld({0: parse_device_spec("0x30"), 1: None, 2: None, 3: None})
    dev = world.ports[0].device
    assert isinstance(dev, MotorDevice)
    world.ports[0].duty = 255
    dev.step(10)
    world.catch_up(400)
    assert dev.physics.pos_deg != 0, "the shaft did not move up to the action"


def _passive_ramp(stops_everything: bool, monkeypatch) -> tuple:
    """A passive light's ramp on the real firmware: (its drive events, the host bytes, the
    firmware's round trips). ``stops_everything``: the stand-in's default, every drive change
    stops the firmware (the world never says otherwise)."""
    from sil_support import firmware_tree

    from buildhat_conformance.sil import process as sil_process
    from buildhat_conformance.sil.build import build_tree
    from buildhat_conformance.sil.hat import SilHat

    program = build_tree(str(firmware_tree())).program
    with monkeypatch.context() as m:
        if stops_everything:
            m.setattr(SilWorld, "sync_drive_stops", lambda self: None)
        runs = []
        real_run = sil_process.FirmwareProcess.run

        def counted(self, *a, **k):
            runs.append(1)
            return real_run(self, *a, **k)
        m.setattr(sil_process.FirmwareProcess, "run", counted)
        hat = SilHat(str(program), devices={0: None, 1: None, 2: "passive 8", 3: None})
        hat.boot()
        before = len(runs)
        hat.write(b"plimit 1 ; port 2 ; set ramp 0 1 5 0 ; version\r")
        hat.advance(1000)
        out = hat.read()
        events = [(e["t"], e["value"]) for e in hat.events if e["dir"] == "pwm" and e.get("port") == 2]
        hat.close()
        return events, out, len(runs) - before


def test_a_passive_port_s_drive_changes_reach_the_world_at_their_times_without_a_stop_each(monkeypatch):
    """A ramp on a light changes the duty every millisecond. The world tells the stand-in that
    such a port's changes need no stop (sil/world.py sync_drive_stops): the events and the bytes
    to the host must be the same as when each change stops the firmware, with far fewer stops."""
    stopped, out_stopped, trips_stopped = _passive_ramp(True, monkeypatch)
    batched, out_batched, trips_batched = _passive_ramp(False, monkeypatch)
    assert len(stopped) >= 40, f"the ramp made only {len(stopped)} drive changes: {stopped[:5]}"
    assert batched == stopped
    assert out_batched == out_stopped
    assert trips_batched < trips_stopped / 3, (trips_batched, trips_stopped)
