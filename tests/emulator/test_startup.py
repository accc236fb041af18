"""Firmware start-up on the command port (FIRMWARE-FACTS §1 "first moments", §5, §10), virtual time."""
from __future__ import annotations

from buildhat_conformance.emulator import Emulator

EMPTY = {0: None, 1: None, 2: None, 3: None}


def timeline(emu: Emulator, ms: int) -> list:
    """[(t, bytes)] of output per millisecond."""
    out = [(emu.now, emu.read())]
    for _ in range(ms):
        emu.advance(1)
        data = emu.read()
        if data:
            out.append((emu.now, data))
    return [x for x in out if x[1]]


def test_banner_and_sequence():
    emu = Emulator(firmware="R7", devices=EMPTY)
    tl = timeline(emu, 420)
    stream = b"".join(d for _, d in tl)
    assert stream == (b"\r\nType help <RETURN> for help\r\n"
                      b"Initialising ports\r\n"
                      b"Resetting drivers: 0123\r\n"
                      b"Reading driver dumps: before port_initdriver(): 0123\r\n"
                      b"Reading driver dumps: after port_initdriver(): 0123\r\n"
                      b"Done initialising ports\r\n")
    t_init = next(when for when, d in tl if d.startswith(b"Initialising"))
    t_reset = next(when for when, d in tl if d.startswith(b"Resetting"))
    t_before = next(when for when, d in tl if b"before" in d)
    t_done = next(when for when, d in tl if b"Done initialising ports" in d)
    assert t_init >= 10                       # at least one 10 ms input-discard wait
    assert t_reset - t_init == 100            # §10: banner; >=10 ms; 100 ms; reset; 100 ms; dumps
    assert t_before - t_reset == 100
    # The dumps take their time: one digit per driver as its registers are read (the firmware in
    # the loop: `Done initialising ports` 403.4 ms after power-on, 393.4 ms after `Initialising`).
    assert 392 <= t_done - t_init <= 395


def test_dump_digits_come_one_driver_at_a_time():
    emu = Emulator(firmware="R7", devices=EMPTY)
    tl = timeline(emu, 420)
    digits = [when for when, d in tl if d in (b"0", b"1", b"2", b"3")]
    # Digits 1..3 of each dump line alone, about 23 ms apart (the 0 comes with its line's text).
    assert len(digits) == 6
    gaps = [b - a for a, b in zip(digits, digits[1:])]
    assert all(22 <= g <= 24 for i, g in enumerate(gaps) if i != 2)


def test_no_prompt_at_startup_and_no_output_after_on_empty_hat():
    emu = Emulator(firmware="R7", devices=EMPTY)
    emu.boot()
    emu.read()
    emu.advance(2000)
    assert emu.read() == b""


def test_input_in_first_moments_is_discarded_one_byte_per_10ms():
    quiet = Emulator(firmware="R7", devices=EMPTY)
    t_quiet = next(w for w, d in timeline(quiet, 400) if d.startswith(b"Initialising"))
    emu = Emulator(firmware="R7", devices=EMPTY)
    emu.write(b"vin\r")                        # 4 bytes at power-on: all thrown away
    tl = timeline(emu, 500)
    t_init = next(w for w, d in tl if d.startswith(b"Initialising"))
    assert t_init - t_quiet == 4 * 10
    assert b"V\r\n" not in b"".join(d for _, d in tl)     # never processed


def test_input_during_port_init_is_kept_and_processed_after_done():
    emu = Emulator(firmware="R7", devices=EMPTY)
    emu.advance(50)                            # past the discard loop, during port init
    assert not emu.hat.ready
    emu.write(b"version\r")
    assert emu.read().find(b"Firmware") < 0
    emu.advance(400)
    out = emu.read()
    done = out.index(b"Done initialising ports\r\n")
    assert out[done:] == (b"Done initialising ports\r\n"
                          b"\r\nFirmware version: 1737564117 2025-01-22T16:41:57+00:00\r\n")


def test_line_observer_sees_early_line_as_not_ready():
    emu = Emulator(firmware="R7", devices=EMPTY)
    records = []
    emu.hat.line_observers.append(records.append)
    emu.advance(50)
    emu.write(b"vin\r")
    emu.boot()
    emu.write(b"port 1 zz\r")
    assert [(r.raw, r.ready, r.error, r.commands, r.unknown) for r in records] == [
        (b"vin", False, False, ["vin"], []),
        (b"port 1 zz", True, True, ["port"], ["zz"]),
    ]


def test_the_controller_tick_counts_from_the_main_loops_first_millisecond():
    # issue 37: the firmware's 10 ms update timer adds up the ticks from the main loop's start, the
    # millisecond of `Done initialising ports` (403.4 ms after power-on: tick 404); the firmware in
    # the loop writes a square wave's drive in (…3, …4] ms of its clock, so at ticks 414, 424 ...
    emu = Emulator(firmware="R7", devices={**EMPTY, 0: "passive 8"})   # a light: the drive shows
    emu.advance(1200)
    assert emu.hat.startup.done_at == 404 and emu.hat.ports[0].connected
    emu.write(b"pwm ; set square 0 1 0.02 0\r")
    emu.advance(100)
    drives = [e["t"] for e in emu.events if e["dir"] == "pwm" and e["port"] == 0]
    assert drives and {t % 10 for t in drives} == {4}
