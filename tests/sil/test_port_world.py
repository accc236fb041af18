"""The firmware in the loop's world skips a motor's samples while what it shows cannot change
(sil/port_world.py): the modes it counts as reading the shaft must be exactly those whose values do."""
from __future__ import annotations

import random

from buildhat_conformance.emulator.devices import MotorDevice, make_device
from buildhat_conformance.protocol.devices import parse_device_spec
from buildhat_conformance.sil.port_world import SHAFT_MODES, SilWorld, shows_shaft


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
    such a port's changes need no stop (sil/port_world.py sync_drive_stops): the events and the bytes
    to the host must be the same as when each change stops the firmware, with far fewer stops."""
    stopped, out_stopped, trips_stopped = _passive_ramp(True, monkeypatch)
    batched, out_batched, trips_batched = _passive_ramp(False, monkeypatch)
    assert len(stopped) >= 40, f"the ramp made only {len(stopped)} drive changes: {stopped[:5]}"
    assert batched == stopped
    assert out_batched == out_stopped
    assert trips_batched < trips_stopped / 3, (trips_batched, trips_stopped)


# A program of the test's own (not a Build HAT firmware): port 0's PIO receiver listens at 2400
# baud and is never read, so its 4-word FIFO fills and the device's later bytes are lost.
RX_PIO = """
.program uart_rx
    wait 0 pin 0
    in pins, 1
    push
"""

NEVER_READ = r"""
#include "pico/stdlib.h"
#include "hardware/pio.h"
#include "uart_rx.pio.h"

int main(void) {
    uint offset = (uint)pio_add_program(pio0, &uart_rx_program);
    pio_sm_config c = uart_rx_program_get_default_config(offset);
    sm_config_set_in_pins(&c, 10);                     /* port 0's RX line */
    sm_config_set_clkdiv(&c, 125000000.0f / (8 * 2400));
    pio_sm_init(pio0, 1, offset, &c);
    pio_sm_set_enabled(pio0, 1, true);
    for (;;) sleep_ms(1);
}
"""


def test_a_byte_lost_to_a_full_pio_rx_fifo_is_said_in_a_note(tmp_path):
    import re
    import shutil

    import pytest

    from buildhat_conformance.sil.build import build_tree
    from buildhat_conformance.sil.hat import SilHat
    if not (shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")):
        pytest.skip("no C compiler on this machine")
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "main.c").write_text(NEVER_READ)
    (tree / "uart_rx.pio").write_text(RX_PIO)
    build = build_tree(str(tree), cache=tmp_path / "cache")
    hat = SilHat(str(build.program), devices={0: "0x30", 1: None, 2: None, 3: None})
    try:
        hat.advance(400)                  # the motor's set-up at 2400 baud: ~4 ms a byte
    finally:
        hat.close()
    sent = bytes.fromhex(" ".join(e["hex"] for e in hat.events if e["dir"] == "devrx" and e["port"] == 0))
    notes = [e["text"] for e in hat.events if e["dir"] == "note" and "PIO RX FIFO was full" in e["text"]]
    assert len(notes) > 50, notes                      # ~90 bytes arrived, 4 of them kept
    assert all(n.startswith("port 0: ") for n in notes), notes
    lost = bytes(int(re.search(r"0x([0-9A-F]{2})", n).group(1), 16) for n in notes)   # type: ignore[union-attr]
    assert lost == sent[4:4 + len(lost)], "the bytes noted are not the device's, from its fifth on"
