"""Firmware timer behaviours of issue 14 item 7, each expectation from FIRMWARE-FACTS (cited).

The emulator runs in virtual time; device data arrive through the device model on P3.
"""
from __future__ import annotations

from buildhat_conformance.emulator.api import Emulator

from .emulator_tap import Tap

EMPTY = {0: "none", 1: "none", 2: "none", 3: "none"}


def motor_on_p3(firmware: str = "R7") -> Tap:
    layout = dict(EMPTY)
    layout[3] = "0x30"
    emu = Emulator(firmware=firmware, devices=layout)
    emu.boot()
    tap = Tap(emu)
    tap.run(1)
    tap.send("port 3")
    tap.run(5)
    return tap


def data_times(tap: Tap, since: int) -> list:
    """When DATA messages from the device on P3 reached the HAT (devrx events)."""
    return [e["t"] for e in tap.devrx(3, since) if int(e["hex"].split()[0], 16) & 0xC0 == 0xC0]


def reports(tap: Tap, since: int, prefix: str = "P3M1:") -> list:
    return [t for t, line in tap.lines if t >= since and line.startswith(prefix)]


# -- §6.2 R5+ per-pass check ---------------------------------------------------------------
def test_selrate_0_reports_the_stored_data_on_the_next_pass():
    # §6.2: "`selrate 0` while messages have arrived since the last report prints the stored
    # data on the very next pass, without waiting for new data."
    tap = motor_on_p3("R7")
    tap.emu.machine.ports[3].set_data_rate(400)      # one DATA message every 400 ms, no more
    tap.send("select 1 ; selrate 1000")              # timed: nothing printed for a second
    tap.run(450)                                     # at least one message has arrived
    assert data_times(tap, 0) and reports(tap, 0) == []
    last = max(data_times(tap, 0))
    t = tap.send("selrate 0")
    tap.run(3)
    assert reports(tap, t) and reports(tap, t)[0] <= t + 2
    assert not [d for d in data_times(tap, last + 1) if d <= t + 2]   # no new message needed


def test_selrate_n_after_a_direct_report_counts_from_the_next_message():
    # §6.2: "`selrate N` right after a direct report starts from a timer held at 0 until the
    # next message arrives, so the first timed report comes N ms after that message."
    tap = motor_on_p3("R7")
    tap.emu.machine.ports[3].set_data_rate(300)
    tap.send("select 1 ; selrate 0")
    tap.run(350)
    assert reports(tap, 0)                           # direct reports happened
    t = tap.send("selrate 50")
    tap.run(400)
    nxt = [d for d in data_times(tap, t + 1)][0]
    timed = reports(tap, t + 1)
    assert timed and timed[0] >= nxt + 50            # never before N ms after that message
    assert timed[0] <= nxt + 51


def test_selrate_0_prints_once_per_new_message_only():
    # §6.2 "Every message (0): at most one report per main-loop pass in which at least one new
    # matching message arrived"; the direct report clears the arrived-message count.
    tap = motor_on_p3("R7")
    tap.emu.machine.ports[3].set_data_rate(200)
    t = tap.send("select 1 ; selrate 0")
    tap.run(1000)
    assert len(reports(tap, t)) == len(data_times(tap, t))
