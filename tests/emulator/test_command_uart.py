"""Baud pacing of the command UART (emulator/command_uart.py, ``buildhat-emulator --baud``), checked in
virtual time: both directions move at the wire rate and the firmware's report throttle sees the
backlog. The real rate against the wall clock is measured by ``make bench`` only."""
from __future__ import annotations

from paced_emulator import PER_MS, booted


def test_input_reaches_the_firmware_at_the_wire_rate() -> None:
    emu = booted()
    lines = []
    emu.hat.line_observers.append(lines.append)
    emu.write(b"port 0\r" * 200)                 # 1400 bytes: ~122 ms on the wire
    emu.advance(61)
    # About half of them crossed: 61 ms carry 702 bytes = 100 lines of 7 bytes; what arrives in a
    # millisecond is run by the next one's pass (the firmware reads its ring as bytes come), so 60 ms'
    # worth of lines have run.
    assert abs(len(lines) - 60 * PER_MS / 7) <= 2
    emu.advance(70)
    assert len(lines) == 200


def test_output_leaves_at_the_wire_rate() -> None:
    emu = booted()
    emu.write(b"help\r")
    got = b""
    for ms in range(1, 301):
        emu.advance(1)
        got += emu.read()
        # Never ahead of the wire (5 input bytes first), never more than a byte behind it.
        assert len(got) <= (ms - 5 / PER_MS) * PER_MS + 2
        if ms > 10:
            assert len(got) >= (ms - 5 / PER_MS - 2) * PER_MS
    assert len(got) <= 2 + 4201


def test_report_throttle_follows_the_paced_backlog() -> None:
    # §6.2 / §11: R5+ print no report while the TX ring holds 4096 bytes or more. Two help
    # texts (8402 bytes, 8192 kept) fill it; on an infinitely fast wire it would stay empty.
    for firmware, throttles in (("R7", True), ("R1", False)):
        emu = booted(firmware, devices={0: "0x30", 1: None, 2: None, 3: None})
        emu.write(b"port 0 ; select 1\r")
        emu.advance(300)
        emu.read()
        emu.write(b"help ; help\r")
        emu.advance(250)                          # the ring still holds > 5000 bytes
        assert emu.hat.tx_pending() > 4096
        # R1 queues its reports behind the help text (the wire has made room); R5+ hold them.
        assert (b"P0M1:" not in bytes(emu.uart.tx)) == throttles, firmware
        emu.advance(1000)                         # drained: reports come back
        assert b"P0M1:" in emu.read()[-200:]
