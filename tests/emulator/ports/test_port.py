"""Port state machine in virtual time: active connect sequence and handshake timing (§5, §8,
§10), data-phase keep-alive and watchdog, passive detection per profile, `disconnected` per
profile, button events, the LED-matrix power rules. Numbers are quoted from FIRMWARE-FACTS.
"""
from __future__ import annotations

import re

import pytest
from emulator_tap import Tap

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.emulator.devices.matrix import POWER_GRACE_MS
from buildhat_conformance.protocol.profiles import get_profile

EMPTY = {0: "none", 1: "none", 2: "none", 3: "none"}
# The device side of the set-up is the emulator model (the facts give only the HAT side): the
# profile value device_setup.baud (docs/EMULATOR-MODELS.md). 8N1: 10 bits per byte.
SETUP_BYTE_MS = 10 * 1000 / get_profile("R7").feature("device_setup")["baud"]


def booted(firmware: str, **ports) -> Tap:
    layout = dict(EMPTY)
    layout.update({int(k[1:]): v for k, v in ports.items()})
    emu = Emulator(firmware=firmware, devices=layout)
    emu.boot()
    tap = Tap(emu)
    tap.run(1)
    return tap


def events(emu: Emulator, kind: str, port: int, since: int = 0):
    return [e for e in emu.events if e["dir"] == kind and e.get("port") == port and e["t"] >= since]


def test_active_connect_sequence_and_handshake_timing():
    tap = booted("R7")
    emu = tap.emu
    t_plug = emu.now
    emu.world("@plug 3 0x30")
    tap.run(3500)
    (t_conn,) = tap.times("P3: connecting to active device")
    scan = get_profile("R7").feature("passive_scan_ms")
    # Found by the next scan (at most one empty-port cycle), then RX held low for 100 ms.
    assert 100 <= t_conn - t_plug <= scan + 100 + 1
    rx = events(emu, "devrx", 3)
    ack = [e for e in rx if e["hex"] == "04"]
    assert len(ack) == 1
    t_ack = ack[0]["t"]
    # The whole setup stream travels at the model's set-up baud after the HAT's 100 ms sync gap.
    setup_bytes = sum(len(e["hex"].split()) for e in rx if e["t"] <= t_ack)
    travel = t_ack - t_conn
    assert setup_bytes * SETUP_BYTE_MS + 100 <= travel <= setup_bytes * SETUP_BYTE_MS + 100 + 50
    tx = events(emu, "dev", 3)
    # §8 / §10: ACK -> +10 ms SPEED `52 00 C2 01 00 6E` -> +100 ms ACK `04` -> +10 ms switch.
    assert (tx[0]["t"] - t_ack, tx[0]["hex"]) == (10, "52 00 C2 01 00 6E")
    assert (tx[1]["t"] - t_ack, tx[1]["hex"]) == (110, "04")
    (t_baud,) = tap.times("set baud rate to 115200")
    assert t_baud - t_ack == 120
    (t_dump,) = tap.times("P3: connected to active ID 30")
    (t_est,) = tap.times("P3: established serial communication with active ID 30")
    assert t_dump - t_baud == 1 and t_est == t_dump
    # Data phase: a bare NACK `02` every 100 ms, unconditionally.
    nacks = [e["t"] for e in tx[2:] if e["hex"] == "02"]
    assert len(nacks) >= 10
    assert {b - a for a, b in zip(nacks, nacks[1:])} == {100}
    assert all(e["hex"] == "02" for e in tx[2:])


@pytest.mark.parametrize("firmware", ["R1", "R2", "R7"])
def test_active_unplug_times_out_after_500ms(firmware):
    tap = booted(firmware, P0="0x30")
    emu = tap.emu
    tap.run(300)
    t_unplug = emu.now
    emu.world("@unplug 0")
    tap.run(800)
    last = max(e["t"] for e in events(emu, "devrx", 0) if e["t"] <= t_unplug)
    (t_timeout,) = tap.times("P0: timeout during data phase: disconnecting")
    assert 500 < t_timeout - last <= 502          # "more than 500 ms without a message"
    gone = tap.times("P0: disconnected")
    if get_profile(firmware).feature("disconnected_line"):
        assert gone == [t_timeout + 1]            # "on the next loop pass"
    else:
        assert gone == []                          # R1 never prints it
    emu.write(b"list\r")
    tap.run(3)
    assert tap.lines[-1][1] == "P3: no device detected"
    assert ("P0: no device detected" in [line for _, line in tap.lines[-4:]])


def test_device_rate_slower_than_watchdog_disconnects_and_reconnects():
    tap = booted("R7", P0="0x3F")
    emu = tap.emu
    emu.world("@rate 0 600")                   # one message every 600 ms: starves the watchdog
    tap.run(1200)
    assert tap.times("P0: timeout during data phase: disconnecting")
    emu.machine.ports[0].set_data_rate(0)     # back to the default (scripts allow 1..1e6)
    tap.run(4000)
    assert tap.times("P0: established serial communication with active ID 3F")


@pytest.mark.parametrize("firmware", ["R1", "R2", "R3", "R7"])
def test_passive_connect_per_profile(firmware):
    profile = get_profile(firmware)
    scan = profile.feature("passive_scan_ms")
    tap = booted(firmware)
    emu = tap.emu
    t_plug = emu.now
    emu.world("@plug 2 passive 1")
    tap.run(2000)
    connects = tap.times("P2: connected to passive ID 1")
    # 6 matching scans in a row (plus up to one empty-port cycle before the first one).
    first = connects[0] - t_plug
    assert 6 * scan <= first <= 6 * scan + profile.feature("empty_port_reset_ms") + 1
    if profile.feature("passive_connect_repeats"):
        # R1: again after every scan, about every 180 ms (100 ms pause + one scan).
        assert len(connects) >= 5
        assert {b - a for a, b in zip(connects, connects[1:])} == {100 + scan}
    else:
        assert len(connects) == 1
    t_unplug = emu.now
    emu.world("@unplug 2")
    tap.run(600)
    after = [t for t in tap.times("P2: connected to passive ID 1") if t > t_unplug]
    gone = tap.times("P2: disconnected")
    if profile.feature("disconnected_line"):
        assert len(gone) == 1 and 0 < gone[0] - t_unplug <= 100 + scan + 1
    else:
        assert gone == []
        assert all(t - t_unplug <= 100 + scan for t in after)   # the repeats just stop


@pytest.mark.parametrize("firmware", ["R1", "R2", "R7"])
def test_button_events_per_profile(firmware):
    tap = booted(firmware, P1="passive 5")
    emu = tap.emu
    tap.run(300)
    t_press = emu.now
    emu.world("@button 1 1")
    tap.run(300)
    emu.world("@button 1 0")
    t_release = emu.now
    tap.run(300)
    pressed, released = tap.times("P1: button pressed"), tap.times("P1: button released")
    if get_profile(firmware).feature("button_events"):
        scan = get_profile(firmware).feature("passive_scan_ms")
        # ID 5 is rescanned continuously: the change shows within one scan.
        assert len(pressed) == 1 and 0 < pressed[0] - t_press <= scan + 1
        assert len(released) == 1 and 0 < released[0] - t_release <= scan + 1
        assert not tap.times("P1: disconnected")
    else:
        assert pressed == released == []


def test_button_held_at_plug_in_reports_right_after_connect():
    tap = booted("R7")
    tap.emu.world("@plug 2 passive 5")
    tap.emu.world("@button 2 1")
    tap.run(1000)
    lines = [line for _, line in tap.lines]
    i = lines.index("P2: connected to passive ID 5")
    assert lines[i + 1] == "P2: button pressed"


@pytest.mark.parametrize("firmware", ["R1", "R3", "R4", "R5", "R6", "R7"])
def test_matrix_autopower_per_profile(firmware):
    # Default layout: the LED matrix (0x40) on P1.
    emu = Emulator(firmware=firmware, devices={0: "none", 2: "none", 3: "none"})
    tap = Tap(emu)
    tap.run(3000)
    (t_est,) = tap.times("P1: established serial communication with active ID 40")[:1]
    pwm = events(emu, "pwm", 1)
    if get_profile(firmware).feature("matrix_autopower"):
        # Constant 1.0 through the default plimit 0.1 -> duty +25 (§7.3), within one 10 ms tick.
        assert pwm and pwm[0]["value"] == 25 and 0 < pwm[0]["t"] - t_est <= 10
        assert not tap.times("P1: timeout during data phase: disconnecting")
    else:
        assert pwm == []
        # Unpowered: the matrix goes quiet after the (documented) grace time, the HAT times out
        # 500 ms later, and the dead matrix does not come back until it is replugged.
        tap.run(POWER_GRACE_MS + 1000)
        (t_out,) = tap.times("P1: timeout during data phase: disconnecting")
        assert POWER_GRACE_MS + 500 < t_out - t_est <= POWER_GRACE_MS + 500 + 110
        tap.run(1500)
        assert len(tap.times("P1: connecting to active device")) == 1
        emu.world("@unplug 1")
        emu.world("@plug 1 0x40")
        tap.run(2500)
        assert len(tap.times("P1: established serial communication with active ID 40")) == 2


def test_matrix_stays_when_the_host_powers_it():
    emu = Emulator(firmware="R5", devices={0: "none", 2: "none", 3: "none"})
    tap = Tap(emu)
    tap.run(2100)       # set up at 2400 baud: established 2.0 s after power-on on the firmware in the loop
    assert tap.times("P1: established serial communication with active ID 40")
    tap.send("port 1 ; on")                    # what python-build-hat does for ID 40
    tap.run(3000)
    assert not tap.times("P1: timeout during data phase: disconnecting")


@pytest.mark.parametrize("firmware", ["R1", "R2", "R7"])
def test_empty_port_resets_controller_every_cycle(firmware):
    """§4.2: settings on an empty port are wiped at every pass through state 0, so a 1 s pulse
    never reports `pulse done`; with a passive device attached (R2+) it does."""
    tap = booted(firmware, P2="passive 1")
    tap.run(200)
    tap.send("port 3 ; set pulse 1 0 1 0 ; port 2 ; set pulse 1 0 1 0")
    tap.run(1500)
    assert tap.times("P3: pulse done") == []
    done = tap.times("P2: pulse done")
    if get_profile(firmware).feature("passive_port_reset_each_scan"):
        assert done == []                      # R1 resets a passive port at every scan too
    else:
        assert len(done) == 1


def test_debug_4_prints_a_signature_line_every_scan():
    tap = booted("R7", P2="passive 8")
    tap.send("debug 4")
    tap.run(1000)
    empty = [t for t, line in tap.lines if line.startswith("P3: D5 signature=")]
    assert all(line.endswith(" id=0") for _, line in tap.lines if line.startswith("P3: D5"))
    cycle = get_profile("R7").feature("empty_port_reset_ms")
    assert {b - a for a, b in zip(empty, empty[1:])} == {cycle}
    passive = [line for _, line in tap.lines if line.startswith("P2: D5 signature=")]
    assert passive and all(line.endswith(" id=8") for line in passive)
    assert all(re.fullmatch(r"P[0-3]: D5 signature=[0-9A-F]{4} id=\d+", line)
               for _, line in tap.lines if "D5" in line)


def test_checksum_error_during_setup_restarts():
    tap = booted("R7")
    emu = tap.emu
    emu.world("@plug 0 0x3F")
    port = emu.machine.ports[0]
    tap.run(400)                                # connecting printed, setup stream under way
    assert tap.times("P0: connecting to active device")
    # Corrupt one byte on the wire (a line glitch) while the setup stream is in flight.
    t, b = port._wire[5]
    port._wire[5] = (t, b ^ 0x01)
    tap.run(6000)
    assert tap.times("P0: checksum error: disconnecting")
    assert tap.times("P0: established serial communication with active ID 3F")


def test_debug_32_reports_setup_info_the_hat_does_not_parse(monkeypatch):
    from buildhat_conformance.emulator.devices import active
    from buildhat_conformance.emulator.ports import lpf2

    real = active.setup_messages

    def with_motor_bias(entry):
        msgs = real(entry)
        # INFO 0x07 (LEGO's "motor bias") for mode 0: not in the HAT's list (§8 "Receiving").
        return msgs[:-1] + [lpf2.info_message(0, 0x07, bytes([5])), msgs[-1]]

    monkeypatch.setattr(active, "setup_messages", with_motor_bias)
    tap = booted("R7")
    tap.send("debug 32")
    tap.run(2)
    tap.emu.world("@plug 0 0x3F")
    tap.run(3500)
    lines = [line for _, line in tap.lines]
    assert re.fullmatch(r"P0: type=80 cmd=07  payload=05", [x for x in lines if "cmd=" in x][0],
                        flags=re.I)
    assert "P0: established serial communication with active ID 3F" in lines


def test_unplug_during_setup_times_out_after_2000ms():
    tap = booted("R7")
    emu = tap.emu
    emu.world("@plug 0 0x3D")
    tap.run(600)                                   # connecting, then part of the stream
    assert tap.times("P0: connecting to active device")
    emu.world("@unplug 0")
    tap.run(2600)
    last = max(e["t"] for e in events(emu, "devrx", 0))
    (t_out,) = tap.times("P0: timeout during setup phase: disconnecting")
    assert 2000 < t_out - last <= 2002             # "more than 2000 ms with no message"
    assert tap.times("P0: disconnected") == []     # it was never connected
    assert not tap.times("set baud rate to 115200")


def test_r1_list_shows_a_passive_device_only_between_scans():
    tap = booted("R1", P2="passive 1")
    seen = set()
    for _ in range(40):
        tap.send("list")
        for _, line in tap.run(9):
            if line.startswith("P2: "):
                seen.add(line)
    # §5: "no device detected" during the ≈80 ms of each scan, connected during the 100 ms pause.
    assert seen == {"P2: no device detected", "P2: connected to passive ID 1"}


def test_r2_list_shows_a_passive_device_all_the_time():
    tap = booted("R2", P2="passive 1")
    seen = set()
    for _ in range(40):
        tap.send("list")
        for _, line in tap.run(9):
            if line.startswith("P2: "):
                seen.add(line)
    assert seen == {"P2: connected to passive ID 1"}


@pytest.mark.parametrize("firmware", ["R1", "R7"])
def test_checksum_errors_in_data_phase_disconnect_after_more_than_5(firmware):
    tap = booted(firmware, P0="0x30")
    port = tap.emu.machine.ports[0]
    tap.send("port 0 ; combi 0 1 0 2 0 3 0 ; select 0 ; selrate 0" if firmware == "R7"
             else "port 0 ; combi 0 1 0 2 0 3 0 ; select 0")
    corrupted = 0
    for _ in range(400):
        tap.run(1)
        if port._wire and corrupted < 6:
            t, b = port._wire[-1]
            port._wire[-1] = (t, b ^ 0xFF)       # a glitch on the checksum byte in flight
            corrupted += 1
    lines = [line for _, line in tap.lines]
    assert "P0: too many errors (0+6): disconnecting" in lines
    i = lines.index("P0: too many errors (0+6): disconnecting")
    follows = lines[i + 1:i + 2]
    if get_profile(firmware).feature("disconnected_line"):
        assert follows == ["P0: disconnected"]
    else:
        assert follows != ["P0: disconnected"]


def test_bad_world_actions_give_clear_errors():
    tap = booted("R7", P0="0x30", P2="passive 8", P3="passive 5")
    ports = tap.emu.machine.ports
    with pytest.raises(ValueError, match="no mode 9"):
        ports[0].device_data(9, b"\x01")
    with pytest.raises(ValueError, match="1..32 bytes"):
        ports[0].device_data(1, bytes(33))
    with pytest.raises(ValueError, match="no active device on port 2"):
        ports[2].device_data(0, b"\x01")
    with pytest.raises(ValueError, match="not a button"):
        ports[2].press_button(True)
    with pytest.raises(ValueError, match="no passive device on port 0"):
        ports[0].press_button(True)
    with pytest.raises(ValueError, match="no motor on port 3"):
        ports[3].hold_shaft(True)
    with pytest.raises((ValueError, KeyError), match="0x99"):
        ports[1].plug("0x99")
    with pytest.raises(ValueError, match="must be >= 0"):
        ports[0].set_data_rate(-1)
    ports[3].press_button(True)                      # the button itself works


def _scan_lines(tap: Tap, port: int):
    return [(t, line) for t, line in tap.lines if line.startswith(f"P{port}: D5 signature=")]


@pytest.mark.parametrize("late_ms, signature", [(1, "00CE"), (23, "04C8"), (45, "0CC0")])
def test_an_active_device_plugged_mid_scan_gives_a_mixed_signature(late_ms, signature):
    # issue 37, seen on the firmware in the loop (`debug 4`): a motor plugged in after the scan's
    # first sample (11 ms after the scan starts, then every 11 ms) leaves the samples before it
    # reading an empty port: `D5 signature=04C8 id=0` for a plug 3 samples late (00CE: 1 sample),
    # so the port scans again and `connecting` comes a scan later.
    scan = get_profile("R7").feature("passive_scan_ms")
    tap = booted("R7")
    emu = tap.emu
    tap.send("debug 4")
    tap.run(scan + 2)
    start = _scan_lines(tap, 3)[-1][0]                         # a scan starts as this one ends
    tap.run(start + 11 + late_ms - 1 - emu.now)                 # the plug comes after sample 0's tick
    emu.world("@plug 3 0x30")
    tap.run(scan + 1)
    (t, line) = _scan_lines(tap, 3)[-1]
    assert line == f"P3: D5 signature={signature} id=0"
    tap.run(scan + 100 + 2)
    (t_conn,) = tap.times("P3: connecting to active device")
    assert t_conn == t + scan + 100                              # the next scan finds it


def test_an_active_device_there_for_the_first_sample_counts():
    scan = get_profile("R7").feature("passive_scan_ms")
    tap = booted("R7")
    emu = tap.emu
    tap.send("debug 4")
    tap.run(scan + 2)
    start = _scan_lines(tap, 3)[-1][0]
    tap.run(start + 10 - emu.now)                               # before the first sample's tick
    emu.world("@plug 3 0x30")
    tap.run(scan)
    (t, line) = _scan_lines(tap, 3)[-1]
    assert (t - start, line) == (scan, "P3: D5 signature=00CF id=99")
