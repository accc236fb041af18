"""The emulator skips milliseconds in which nothing is due (``Hat.advance``, ``Port.due``, the
devices' lazy sampling and jitter draws): that must never change what happens when.

Each scenario runs twice: as the emulator normally runs (``advance`` in chunks, skipping), and
in a reference mode that ticks every port, controller and the fault monitor every millisecond
and makes every device sample afresh (what the emulator did before it skipped anything). The
output bytes, with the virtual millisecond each was written, and the events must be identical.
"""
from __future__ import annotations

import json
from contextlib import contextmanager
from typing import Iterator, List, Optional, Sequence, Tuple

import pytest

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.emulator.devices import ActiveDevice
from buildhat_conformance.emulator.hat import Hat

Plan = Sequence[Tuple[int, str]]     # (ms after boot, host line or @world action)

MIXED = {0: "0x30", 1: "0x40", 2: "0x3D", 3: "0x31"}
MOTORS = {0: "0x30", 1: "0x31", 2: "0x41", 3: "0x3E"}
STREAM = "port 0 ; select 0 ; port 1 ; select 0 ; port 2 ; select 0 ; port 3 ; select 0"
# The R1-R5 pid form first: on R6+ it fails (PWM mode) and the 11-number form follows.
PID_OLD = "port 0 ; plimit 1 ; pid 0 0 5 s2 0.0027777778 1 5 0.5 0.1 3"
PID_NEW = PID_OLD + " 0.01"

CONTROL: Plan = [
    (0, "echo 1"), (5, STREAM), (60, "port 0 ; combi 0 1 0 2 0 3 0 ; select 0"),
    (100, PID_OLD + " ; debug 16 ; set square 0 1 2 0"), (101, PID_NEW + " ; set square 0 1 2 0"),
    (150, "port 3 ; plimit 0.6 ; set pulse 0.5 0 1 0"), (300, "port 2 ; set -1"),
    (1200, "port 3 ; set ramp 0 -0 0.7 0"), (1900, "port 0 ; set sine -1 1 1.3 0.25"),
    (2000, "port 1 ; selrate 20"), (2100, "port 2 ; selonce 1"), (2300, "@hold 0 1"),
    (2600, "@hold 0 0"), (2800, "@pos 0 90"), (3000, "@data 2 0 01 02"), (3100, "@data 2 0 auto"),
    (3200, "@motorfault 1 3"), (3500, "@portfault 1"), (4600, "@portfault 0"),
    (4700, "@motorfault 0"), (4800, "clear_faults"), (4900, "debug 9"), (5000, "debug 0"),
    (5100, "port 3 ; coast"), (5300, "port 3 ; pwm ; set square 0 -0 0.1 0"),
    (5500, "@rate 1 50"), (6000, "@rate 1 700"), (7300, "@unplug 2"),
    (7600, "@plug 2 0x3E"), (8300, "port 2 ; select 1"), (8400, "@adc 800"),
    (8500, "ledmode 2"), (8600, "ledmode -1"), (8601, "@adc 1742"), (8700, "port 1 ; off"),
    (8800, "port 1 ; on ; list"),
]
AT_REST: Plan = [
    (0, "port 0 ; select 3"), (0, "port 1 ; combi 1 4 0 1 0 ; select 1"), (0, "port 2 ; select 0"),
    (1, "port 3 ; select 0"), (750, "port 0 ; selrate 0"), (1250, "port 0 ; selrate 37"),
    (1550, "@rate 0 30"), (1800, "port 0 ; selrate 0"),
    (2100, "port 1 ; select 2 ; selrate 0"), (2150, "port 2 ; select 3 ; selrate 5"),
    (2500, "@hold 2 1"), (2500, "port 2 ; plimit 1 ; set 0.5"), (2900, "@hold 2 0"),
    (3200, "port 2 ; set 0"), (3202, "port 2 ; coast"), (3750, "@pos 2 45"),
    (4000, "port 3 ; set -1"), (4250, "port 3 ; select 1"), (4500, "port 0 ; write1 c3 01"),
    (4750, "port 1 ; selonce 3"), (5000, "@motorfault 1 1"), (5100, "port 1 ; set 0.3"),
    (5650, "@motorfault 0"), (5650, "clear_faults"), (5900, "@unplug 3"),
    (6250, "@plug 3 0x3F"), (6900, "port 3 ; select 4"),
]
PASSIVE: Plan = [
    (0, "port 0 ; select 0"), (0, "@plug 2 passive 5"), (400, "@button 2 1"), (700, "@button 2 0"),
    (500, "port 0 ; set 0.5"), (900, "port 0 ; coast"), (1200, "port 1 ; set 0"),
    (2500, "@unplug 1"), (3000, "@plug 3 passive 5"), (3500, "@button 3 1"),
    (3900, "@button 3 0"), (4200, "@plug 1 0x40"), (4300, "port 1 ; plimit 1 ; set 1"),
]

# Hot-plugs whose device falls silent (``!mute``, as an unpowered light matrix does) during the
# setup messages, right after its ACK and in the data phase: the link's own timeouts (2000 ms
# setup, 500 ms data) and the handshake steps fall in milliseconds the skipping run jumps over.
SILENCED: Plan = [
    (0, "@unplug 1"), (0, "@unplug 2"), (0, "@unplug 3"), (200, "@plug 1 0x30"), (210, "@plug 2 0x3D"),
    (230, "@plug 3 0x41"), (480, "!mute 1"), (1500, "!mute 3"), (2600, "port 0 ; list"),
    (4000, "@unplug 1"), (4000, "@plug 1 0x31"), (4010, "list"),
]


def _tick_everything(hat: Hat) -> None:
    """Reference mode: every object is due now and every device samples afresh."""
    hat.wake()
    for port in hat.ports:
        port.due = 0
        if isinstance(port.device, ActiveDevice):
            port.device.inputs_changed()
    for controller in hat.controllers:
        controller.due = 0
    hat.faults.due = 0


def _run(firmware: str, devices: Optional[dict], plan: Plan, total_ms: int, reference: bool,
         baud: Optional[int] = None, until_output: bool = False) -> List[tuple]:
    emu = Emulator(firmware=firmware, devices=devices, baud=baud)
    log: List[tuple] = []
    emu.on_event(lambda e: log.append(("event", json.dumps(e, sort_keys=True, default=str))))
    deliver = emu.uart._deliver

    def stamped(data: bytes) -> None:      # every output write, with its virtual ms
        log.append(("out", emu.machine.now, bytes(data)))
        deliver(data)

    emu.uart._deliver = stamped            # type: ignore[method-assign]
    emu.boot()
    start = emu.now

    def running_hat() -> Hat:                 # the running firmware (a world @reset starts a new one)
        hat = emu.hat
        assert hat is not None             # built without the bootloader
        return hat

    for t, action in sorted(plan, key=lambda a: a[0]) + [(total_ms, "")]:
        while emu.now < start + t:
            if reference:
                _tick_everything(running_hat())
                emu.step()
            elif until_output:                 # as the in-process target reads
                emu.advance_until_output(min(7, start + t - emu.now))
                emu.read()
            else:
                emu.advance(min(7, start + t - emu.now))   # uneven chunks: jumps cross them
        if action.startswith("!mute"):       # the device stops talking for good (dead)
            port = running_hat().ports[int(action.split()[1])]
            assert isinstance(port.device, ActiveDevice), action
            port.device.dead = True
            port.wake()
            log.append(("world", emu.now, action))
        elif action.startswith("@"):
            log.append(("world", emu.now, action, emu.world(action)))
        elif action:
            emu.write(action.encode("ascii") + b"\r")
    return log


@pytest.mark.parametrize("firmware", ["R1", "R4", "R7"])
@pytest.mark.parametrize("devices,plan,total_ms,baud", [
    (MIXED, CONTROL, 9500, None),
    (MOTORS, AT_REST, 7500, None),
    (None, PASSIVE, 5500, None),
    (MIXED, CONTROL[:12], 2500, 115200),
    (MIXED, SILENCED, 5500, None),
], ids=["control", "motors-at-rest", "passive", "paced", "silenced-hot-plugs"])
def test_skipping_idle_milliseconds_changes_nothing(firmware, devices, plan, total_ms, baud):
    reference = _run(firmware, devices, plan, total_ms, reference=True, baud=baud)
    skipping = _run(firmware, devices, plan, total_ms, reference=False, baud=baud)
    assert len(reference) > 200
    assert skipping == reference
    reading = _run(firmware, devices, plan, total_ms, reference=False, baud=baud, until_output=True)
    assert reading == reference


@contextmanager
def ticked_ms() -> Iterator[List[int]]:
    """The milliseconds the HAT ticks (``Hat._run_due``) while the block runs."""
    ticks: List[int] = []
    real = Hat._run_due

    def counted(hat: Hat, now: int) -> None:
        ticks.append(now)
        real(hat, now)

    Hat._run_due = counted                 # type: ignore[method-assign]
    try:
        yield ticks
    finally:
        Hat._run_due = real                # type: ignore[method-assign]


def test_idle_milliseconds_are_skipped():
    emu = Emulator()
    emu.boot()
    emu.advance(1000)
    with ticked_ms() as ticks:
        emu.advance(1000)
    # The controllers' 10 ms updates at least; far from every millisecond.
    assert 100 <= len(ticks) <= 400


def test_a_hot_plug_handshake_is_skipped_through():
    """Between the device's messages and the handshake's steps the port waits: those ms are
    not ticked (they were, every one, before the link said when it is next due)."""
    emu = Emulator(devices={0: None, 1: None, 2: None, 3: None})
    emu.boot()
    emu.advance(100)
    with ticked_ms() as ticks:
        emu.world("@plug 0 0x3D")          # a sensor: no motor physics, only the link
        emu.advance(4500)                  # setup, handshake, data
    assert emu.hat.ports[0].established
    assert len(ticks) < 2000, len(ticks)
