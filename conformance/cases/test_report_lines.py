"""The exact bytes of data lines whose form the facts fix (docs/FIRMWARE-BEHAVIOUR.md#fb-data-lines,
#fb-float, #fb-debug): a known payload is put on the device's wire with the world's ``@data``, so
every character of the line the HAT prints is known in advance. Without ``@data`` a hardware rig
cannot choose a payload; those runs check the forms leniently in test_select.py.
"""
from __future__ import annotations

import re
import struct
from typing import List

import pytest

from ..hat_under_test import HatUnderTest
from ..needs import PortNeeds


def _hex(payload: bytes) -> str:
    return " ".join(f"{b:02X}" for b in payload)


def lines_with(hat: HatUnderTest, world: PortNeeds, port: int, mode: int, payload: bytes, line: str,
               head: str,
               count: int = 2) -> List[str]:
    """The port's lines starting with ``head`` once ``payload`` is mode ``mode``'s data and
    ``line`` ran (at least ``count`` of them, or all there were after 2 s of HAT time)."""
    world.require("data", "choosing what a device sends (@data)")
    world.action(f"@data {port} {mode} {_hex(payload)}")
    try:
        reply = hat.exchange(f"port {port} ; {line}")
        assert reply.errors == 0, f"`{line}`: {reply.raw!r}"
        events = reply.events + hat.wait_for(lambda e: e.text.startswith(head), count, 2000)
    finally:
        hat.exchange("select ; debug 0")
        world.action(f"@data {port} {mode} auto")
    return [e.text for e in events if e.text.startswith(head)]


def last_data_line(lines: List[str], head: str) -> str:
    assert lines, f"no line starting {head!r} within 2 s of HAT time"
    return lines[-1]


# Mode 1 SPEED int8, mode 2 POS int32, mode 3 APOS int16 (devices.json, the SPIKE medium motor).
# FIRMWARE-BEHAVIOUR#fb-data-lines: `+N`, `-N`, or a space then `0`; little-endian, signed.
MODE_CASES = [
    (1, b"\x05", "+5"), (1, b"\x00", " 0"), (1, b"\xfb", "-5"), (1, b"\x80", "-128"), (1, b"\x7f", "+127"),
    (3, b"\x4c\xff", "-180"), (3, b"\xb3\x00", "+179"), (3, b"\x00\x80", "-32768"),
    (2, b"\x68\x01\x00\x00", "+360"), (2, b"\x00\x00\x00\x80", "-2147483648"), (2, b"\x00\x00\x00\x00", " 0"),
]


@pytest.mark.req("CMD-SELECT-MODE", "DEV-MODES")
@pytest.mark.parametrize("mode,payload,value", MODE_CASES,
                         ids=[f"M{m}-{p.hex()}" for m, p, _v in MODE_CASES])
def test_mode_line_bytes(hat: HatUnderTest, world: PortNeeds, motor_port: int, mode: int, payload: bytes,
                         value: str) -> None:
    p = motor_port
    head = f"P{p}M{mode}:"
    lines = lines_with(hat, world, p, mode, payload, f"select {mode}", head)
    assert last_data_line(lines, head) == f"{head} {value}", \
        f"the device sent {payload.hex(' ')}: expected `{head} {value}`, came {last_data_line(lines, head)!r}"


@pytest.mark.req("CMD-COMBI", "EX-MOTOR-COMBI")
def test_combi_line_bytes(hat: HatUnderTest, world: PortNeeds, motor_port: int) -> None:
    # FIRMWARE-BEHAVIOUR#fb-data-lines: the values are read back to back in each entry's mode type
    # (M1 int8, M2 int32, M3 int16); the document's own example line is `P3C0: +5 +360 -180`.
    # The device packs each entry's dataset from that mode's data, so each mode gets its payload.
    p = motor_port
    head = f"P{p}C0:"
    world.require("data", "choosing what a device sends (@data)")
    world.action(f"@data {p} 1 05")
    world.action(f"@data {p} 2 68 01 00 00")
    hat.exchange(f"port {p} ; combi 0 1 0 2 0 3 0")
    try:
        lines = lines_with(hat, world, p, 3, b"\x4c\xff", "select 0", head)
    finally:
        hat.exchange(f"port {p} ; combi 0")
        world.action(f"@data {p} 1 auto")
        world.action(f"@data {p} 2 auto")
    assert last_data_line(lines, head) == f"{head} +5 +360 -180", \
        f"expected the document's line `{head} +5 +360 -180`, came {last_data_line(lines, head)!r}"


# FIRMWARE-BEHAVIOUR#fb-float steps 1-2: the sign first, then `Inf` / `NaN` for an all-ones
# exponent and `0.00000` for a zero one (zero and subnormals).
FLOAT_CASES = [
    (b"\x00\x00\x80\x7f", "Inf"), (b"\x00\x00\x80\xff", "-Inf"), (b"\x00\x00\xc0\x7f", "NaN"),
    (b"\x00\x00\xc0\xff", "-NaN"), (b"\x00\x00\x00\x80", "-0.00000"), (b"\x01\x00\x00\x00", "0.00000"),
] + [(struct.pack("<f", value), text) for value, text in [
    # Steps 5-7: E notation below 0.01 and from 10^6; six digits, the point omitted at e = 5.
    (123456.4, "123456"), (999999.5, "1.00000E6"), (1234567, "1.23457E6"), (0.1, "0.100000"),
    (0.01, "0.0100000"), (0.001, "1.00000E-3"), (65535, "65535.0"), (-180, "-180.000")]]


@pytest.mark.req("CMD-SELECT-VAR", "FW-FLOAT-PRINTER")
@pytest.mark.parametrize("payload,text", FLOAT_CASES, ids=[t for _p, t in FLOAT_CASES])
def test_variable_line_prints_special_floats(hat: HatUnderTest, world: PortNeeds, motor_port: int,
                                             payload: bytes,
                                            text: str) -> None:
    p = motor_port
    head = f"P{p}V:"
    lines = lines_with(hat, world, p, 4, payload, "select 4 0 f4", head)
    assert last_data_line(lines, head) == f"{head} {text}", \
        f"the device sent {payload.hex(' ')}: expected `{head} {text}` " \
        f"(docs/FIRMWARE-BEHAVIOUR.md#fb-float), " \
        f"came {last_data_line(lines, head)!r}"


@pytest.mark.req("CMD-DEBUG", "FW-DEBUG-8")
@pytest.mark.parametrize("mode,payload", [(1, b"\x05"), (3, b"\x4c\xff"), (2, b"\x68\x01\x00\x00")],
                         ids=["M1", "M3", "M2"])
def test_debug_8_prints_each_data_payload(hat: HatUnderTest, world: PortNeeds, motor_port: int, mode: int,
                                          payload: bytes) -> None:
    # FIRMWARE-BEHAVIOUR#fb-debug, bit 8: `P<p>: DATA mode=<hex digit> payload=xx xx ...`, single
    # spaces, none at the end. The document does not fix the letters' case: either is taken.
    p = motor_port
    head = f"P{p}: DATA mode="
    lines = lines_with(hat, world, p, mode, payload, f"select {mode} ; debug 8", head)
    form = re.compile(rf"P{p}: DATA mode=[0-9A-Fa-f] payload=[0-9A-Fa-f]{{2}}(?: [0-9A-Fa-f]{{2}})*")
    assert lines, f"no `{head}` line within 2 s of HAT time with debug 8"
    bad = [ln for ln in lines if not form.fullmatch(ln)]
    assert not bad, f"not the debug 8 form: {bad[:3]}"
    ours = [ln for ln in lines if ln.upper() == f"P{p}: DATA MODE={mode:X} PAYLOAD={_hex(payload)}"]
    assert ours, f"no line shows mode {mode}'s payload {_hex(payload)}: {lines[-3:]}"
