"""Firmware timer behaviours of issue 14 item 7, each expectation from FIRMWARE-FACTS (cited).

The emulator runs in virtual time; device data arrive through the device model on P3.
"""
from __future__ import annotations

import re

import pytest
from emulator_tap import Tap, motor_on_p3

from buildhat_conformance.emulator.api import Emulator

EMPTY = {0: "none", 1: "none", 2: "none", 3: "none"}


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


# -- §7.4 debug 4: passive-ID signatures ------------------------------------------------------
SIG_LINE = re.compile(r"P([0-3]): D5 signature=([0-9A-F]{4}) id=(\d+)")


def signature_lines(firmware: str, layout: dict, ms: int = 400, then=None) -> list:
    emu = Emulator(firmware=firmware, devices={**EMPTY, **layout})
    emu.boot()
    tap = Tap(emu)
    tap.send("debug 4")
    if then:
        emu.world(then)
    tap.run(ms)
    return [(int(m[1]), int(m[2], 16), int(m[3])) for _, line in tap.lines
            if (m := SIG_LINE.fullmatch(line))]


@pytest.mark.parametrize("firmware", ["R2", "R7"])
def test_debug_4_shows_a_possible_active_device_as_id_99(firmware):
    # §7.4: "a signature whose & 0x00EF is 0x00CF prints id=99 ('possibly an active device',
    # which then starts active-ID detection)".
    found = [(sig, pid) for port, sig, pid in signature_lines(firmware, {}, then="@plug 3 0x30")
             if port == 3]
    active = [(sig, pid) for sig, pid in found if sig & 0x00EF == 0x00CF]
    assert active and all(pid == 99 for _, pid in active)
    assert all(pid == 0 for sig, pid in found if sig & 0x00EF != 0x00CF)


# §7.4 tables: R1/R2 "0x0080->1, ..., 0x0C80->8", R3+ "0x0040->1, ..., 0x0C40 (and 0x1C40)->8";
# both "0x0CC0->0" (nothing connected).
TABLE = {
    "v1": {1: {0x0080}, 8: {0x0C80}, 11: {0x08C0}, 7: {0xFF80}, 0: {0x0CC0}},
    "v2": {1: {0x0040}, 8: {0x0C40, 0x1C40}, 11: {0x04C0}, 7: {0xFF40}, 0: {0x0CC0, 0x1CC0}},
}


@pytest.mark.parametrize("firmware,table", [("R1", "v1"), ("R2", "v1"), ("R3", "v2"), ("R7", "v2")])
@pytest.mark.parametrize("pid", [1, 7, 8, 11])
def test_debug_4_uses_the_releases_signature_table(firmware, table, pid):
    lines = signature_lines(firmware, {2: f"passive {pid}"})
    on_p2 = {(sig, got) for port, sig, got in lines if port == 2}
    assert on_p2 and all(got == pid and sig in TABLE[table][pid] for sig, got in on_p2)
    empty = {(sig, got) for port, sig, got in lines if port == 0}
    assert empty and all(got == 0 and sig in TABLE[table][0] for sig, got in empty)


@pytest.mark.parametrize("firmware,pressed", [("R2", {0x8888, 0x8C8C, 0xC8C8}),
                                              ("R7", {0x4444, 0x4C4C, 0xC4C4})])
def test_debug_4_button_signatures_per_table(firmware, pressed):
    # §7.4: button (5) = 0x8888/0x8C8C/0xC8C8/0xCCCC (R1/R2), 0x4444/0x4C4C/0xC4C4/0xCCCC (R3+);
    # §5: pressed means the raw signature is not 0xCCCC.
    lines = signature_lines(firmware, {2: "passive 5"}, ms=800, then="@button 2 1")
    on_p2 = {(sig, pid) for port, sig, pid in lines if port == 2}
    assert on_p2 and all(pid == 5 and sig in pressed for sig, pid in on_p2)


# -- §4.4 / §10: the ADC is sampled once per 1 ms tick -----------------------------------------
def test_adc_change_shows_in_vin_from_the_next_tick():
    # §10 "Main-loop tick: 1 ms (gettick; the ADC and LEDs are also refreshed every 1 ms)";
    # §4.4 vin "is refreshed every 1 ms": a `vin` in the same millisecond as the change still
    # prints the previous sample. 1742 -> 8.00 V and 2000 -> 9.18 V by the §4.4 formula.
    emu = Emulator(firmware="R7", devices=EMPTY)
    emu.boot()
    emu.read()
    emu.world("@adc 2000")
    emu.write(b"vin\r")
    assert emu.read() == b"\r\n8.00 V\r\n"
    emu.advance(1)
    emu.write(b"vin\r")
    assert emu.read() == b"\r\n9.18 V\r\n"


# -- LED matrix grace (emulator model, profile value) -------------------------------------------
def test_matrix_grace_is_profile_data_and_booted_leaves_the_host_all_of_it():
    # The facts give no time (DEVICES.md: "needs motor power soon after setup"); the grace is
    # the profile value matrix_power_grace_ms. A booted HAT (`--booted`, emulator.boot()) is
    # what a host finds when it opens the port, so the grace counts from then: powering the
    # matrix just before the grace ends keeps it (R5 has no auto-power, §11).
    from buildhat_conformance.protocol.profiles import get_profile
    grace = get_profile("R5").feature("matrix_power_grace_ms")
    for power_at, survives in ((grace - 20, True), (grace + 30, False)):
        emu = Emulator(firmware="R5", devices={0: "none", 2: "none", 3: "none"})
        emu.boot()
        tap = Tap(emu)
        tap.run(power_at)
        tap.send("port 1 ; on")
        tap.run(1000)
        dead = bool(tap.times("P1: timeout during data phase: disconnecting"))
        assert dead is not survives, (power_at, grace)


# -- start-up and device set-up timing (§5, §8, §10; the device side is a profile value) -------
HANDSHAKE_MS = 10 + 100 + 10 + 1    # §10 "ACK -> +10 ms SPEED -> +100 ms ACK -> +10 ms switch -> +1 ms"


def established_after(emu: Emulator, port: int, limit_ms: int = 5000) -> int:
    """Milliseconds from now until `P<port>: established serial communication ...` (§5)."""
    start, buf = emu.now, b""
    want = b"P%d: established serial communication" % port
    while want not in buf:
        assert emu.now - start < limit_ms, buf[-300:]
        emu.step()
        buf += emu.read()
    return emu.now - start


SPIKE_MOTOR_SETUP_BYTES = 493     # the 0x30 motor's set-up stream (docs/EMULATOR-MODELS.md)


@pytest.mark.parametrize("firmware", ["R1", "R3", "R7"])
def test_hot_plugged_motor_sets_up_at_2400_baud(firmware):
    # Issue 37: the port listens at 2400 baud until the handshake (fb-active), so a motor's set-up
    # stream alone takes 493 bytes x 10 bits / 2400 = 2.05 s. The HAT's own share is fixed by the
    # facts: detection by the next scan, RX held low 100 ms (§5), the 100 ms receive-sync gap (§8)
    # and the 121 ms handshake (§10).
    emu = Emulator(firmware=firmware, devices=EMPTY)
    emu.boot()
    emu.read()
    emu.world("@plug 2 0x30")
    took = established_after(emu, 2, limit_ms=5000)
    stream_ms = SPIKE_MOTOR_SETUP_BYTES * 10 * 1000 // 2400
    assert 100 + 100 + HANDSHAKE_MS + stream_ms <= took <= 100 + 100 + HANDSHAKE_MS + stream_ms + 400


def test_fast_setup_only_when_asked():
    # A faster set-up for test suites (fast_setup): the same motor well under a second.
    emu = Emulator(firmware="R7", devices=EMPTY, fast_setup=True)
    emu.boot()
    emu.read()
    emu.world("@plug 2 0x30")
    assert established_after(emu, 2) <= 1000


@pytest.mark.parametrize("firmware", ["R1", "R7"])
def test_start_up_with_the_default_devices_sets_up_at_the_real_rate(firmware):
    # §5/§10: the firmware boot alone is >= 10 + 100 + 100 ms before `Done initialising ports`;
    # the default layout's motor then sets up at 2400 baud (2.05 s of stream), so the boot ends
    # after about 3 s (the firmware in the loop: 2990 ms, issue 37), on a 10 ms step.
    emu = Emulator(firmware=firmware)
    took = emu.boot()
    stream_ms = SPIKE_MOTOR_SETUP_BYTES * 10 * 1000 // 2400
    assert 210 + 100 + 100 + HANDSHAKE_MS + stream_ms <= took <= 3500
    assert took % 10 == 0


# -- §7.1 when a pulse's `done` comes ----------------------------------------------------------
@pytest.mark.parametrize("length,ticks", [("1", 101), ("5", 500)])
def test_pulse_done_comes_on_its_tick_count_after_the_line_at_every_phase(length, ticks):
    # §7.1: "the end occurs after N ticks with ... 1 -> 101; 5 -> 500 ... N counts the port's ticks
    # after the command, and the first tick is 0-10 ms after it": `done` comes (N-1)*10 to N*10 ms
    # after the CR, whatever the line's phase against the 10 ms timer. For 5 s that is up to 10 ms
    # before 5 s (issue 27: a host's clock sees the full 5 s only through the wire's time).
    tap = motor_on_p3("R7")
    tap.send("pwm ; set 0")
    after = []
    for _phase in range(10):
        tap.run(1)                  # with the 10*(ticks+2) ms below: each line 1 ms later in the cycle
        t = tap.send(f"set pulse 0 0 {length} 0")
        tap.run(ticks * 10 + 20)
        done = [d for d in tap.times("P3: pulse done") if d > t]
        assert len(done) == 1, done
        after.append(done[0] - t)
    assert all((ticks - 1) * 10 <= a <= ticks * 10 for a in after), after
    assert len(set(after)) == 10, after              # every phase of the cycle was tried
