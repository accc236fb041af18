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
