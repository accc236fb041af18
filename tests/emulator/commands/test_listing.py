"""`list` and the connect dump for every device of devices.json, through the whole emulator:
the device model sends its setup stream over the emulated wire, the HAT parses it, and
`list` renders the parsed record. The oracle is each device's ``hat_list_lines`` (real
dumps / the §4.4 rules), with the port number substituted.
"""
from __future__ import annotations

import re

import pytest

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.protocol.devices import active_device, active_type_ids, passive_ids

EMPTY = {0: "none", 1: "none", 2: "none", 3: "none"}


def lines_of(data: bytes):
    text = data.decode("latin-1")
    assert text.endswith("\r\n") or text == ""
    return text.split("\r\n")[:-1] if text else []


def expected_block(type_id: int, port: int):
    block = active_device(type_id)["hat_list_lines"]
    return [f"P{port}" + line[2:] if line.startswith("P0") else line for line in block]


def _groups(seq, n):
    return [seq[i:i + n] for i in range(0, len(seq), n)]


@pytest.mark.parametrize("types", _groups(active_type_ids(), 4),
                         ids=lambda ts: "+".join(f"{t:02X}" for t in ts))
def test_list_equals_real_dump_for_every_active_device(types):
    layout = dict(EMPTY)
    for port, t in enumerate(types):
        layout[port] = f"0x{t:02X}"
    emu = Emulator(firmware="R7", devices=layout)
    emu.boot()
    boot_out = lines_of(emu.read())
    emu.write(b"list\r")
    emu.advance(20)
    out = lines_of(emu.read())
    assert out[0] == ""                               # the CRLF the CR produced
    expected = []
    for port in range(4):
        if port < len(types):
            expected += expected_block(types[port], port)
        else:
            expected.append(f"P{port}: no device detected")
    assert out[1:1 + len(expected)] == expected
    # §5: a long `list` stretches its main-loop pass; the next pass may print `deltat=` (8 hex).
    assert all(re.fullmatch(r"deltat=[0-9A-F]{8}", line) for line in out[1 + len(expected):])
    # The same block appears on connect, after `connecting` and `set baud rate` (no port
    # prefix, so with identical devices the ports' lines interleave) and before `established`.
    assert boot_out.count("set baud rate to 115200") == len(types)
    for port, t in enumerate(types):
        block = expected_block(t, port)
        start = boot_out.index(block[0])
        assert boot_out[start:start + len(block)] == block
        assert boot_out[start + len(block)] == \
            f"P{port}: established serial communication with active ID {t:02X}"
        connecting = boot_out.index(f"P{port}: connecting to active device")
        assert "set baud rate to 115200" in boot_out[connecting:start]


def test_list_passive_and_empty_lines():
    ids = passive_ids()
    for first in range(0, len(ids), 4):
        chunk = ids[first:first + 4]
        layout = dict(EMPTY)
        for port, pid in enumerate(chunk):
            layout[port] = f"passive {pid}"
        emu = Emulator(firmware="R7", devices=layout)
        emu.boot()
        emu.read()
        emu.write(b"list\r")
        emu.advance(5)
        out = lines_of(emu.read())[1:]
        expected = [f"P{p}: connected to passive ID {pid}" for p, pid in enumerate(chunk)]
        expected += [f"P{p}: no device detected" for p in range(len(chunk), 4)]
        assert out == expected


def test_list_does_not_show_a_device_still_in_setup():
    emu = Emulator(firmware="R7", devices={**EMPTY, 2: "0x3D"})
    emu.boot()                                    # boot waits for the layout; unplug, replug
    emu.world("@unplug 2")
    emu.advance(700)                              # watchdog 500 ms + rescan
    emu.world("@plug 2 0x3D")
    emu.advance(400)                              # detection done, setup stream in progress
    out = emu.read().decode("latin-1")
    assert "P2: connecting to active device" in out
    emu.write(b"list\r")
    emu.advance(2)
    assert "P2: no device detected" in lines_of(emu.read())


def test_range_conversion_saturates_like_the_rp2040():
    # §4.4: truncation toward zero; negative -> 00000000; >= 2^32 -> FFFFFFFF.
    from buildhat_conformance.emulator.commands.listing import combi_text, float_to_uint
    assert [float_to_uint(x) for x in (-180.0, -0.5, 0.0, 179.9, 360.0, 4294967296.0, 1e30)] == \
        [0, 0, 0, 179, 360, 0xFFFFFFFF, 0xFFFFFFFF]
    assert combi_text(0b1110) == "M1+M2+M3"
    assert combi_text(0x4F) == "M0+M1+M2+M3+M6"


def test_list_prints_what_the_hat_parsed_not_the_catalogue():
    """A device that sends a different setup stream is listed as sent: the dump comes from the
    parsed messages (here: VERSION words swapped, an empty symbol, no PIDs, extended MODES)."""
    from buildhat_conformance.emulator.commands.listing import active_dump
    from buildhat_conformance.emulator.devices.info import DeviceInfo
    from buildhat_conformance.emulator.ports import lpf2
    info = DeviceInfo()
    stream = [
        lpf2.device_message(lpf2.CMD, lpf2.CMD_TYPE, bytes([0x30])),
        lpf2.device_message(lpf2.CMD, lpf2.CMD_MODES, bytes([7, 7, 9, 1])),
        lpf2.device_message(lpf2.CMD, lpf2.CMD_VERSION, bytes.fromhex("00000010 04000000")),
        lpf2.info_message(9, lpf2.INFO_NAME, b"X9\x00\x00\x00\x00\x40\x00\x00\x00\x05\x04"),
        lpf2.info_message(9, lpf2.INFO_SYMBOL, b"\x00"),
        lpf2.info_message(9, lpf2.INFO_RAW, bytes.fromhex("000034C3 0000B443")),   # -180 .. 360
    ]
    for raw in stream:
        (msg,) = lpf2.parse_all(raw)
        assert info.apply(msg)
    assert active_dump(2, info) == [
        "P2: connected to active ID 30",
        "type 30",
        "  nmodes =9",
        "  nview  =1",
        "  baud   =0",
        "  hwver  =10000000",
        "  swver  =00000004",
        "  M9 X9 SI = ",
        "    format count=0 type=0 chars=0 dp=0",
        "    RAW: 00000000 00000168    PCT: 00000000 00000000    SI: 00000000 00000000",
        "     speed PID: 00000000 00000000 00000000 00000000",
        "  position PID: 00000000 00000000 00000000 00000000",
    ]
