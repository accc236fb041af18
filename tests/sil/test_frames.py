"""Frames between the world and the firmware (sil/frames.py), laid out by hand from the module's
documented header (type letter, port, payload length, 4 spare bytes, virtual ns; little-endian) and
checked against the C end's struct (sil/standin/frame_transport.c, our stand-in's code)."""
from __future__ import annotations

import re

import pytest
from repo_paths import REPO

from buildhat_conformance.sil.frames import HEADER, decode, encode


def test_a_frame_is_the_documented_header_then_the_payload():
    frame = encode("H", t=5_000_000, payload=b"vin\r")
    header = b"H" + b"\x00" + (4).to_bytes(2, "little") + bytes(4) + (5_000_000).to_bytes(8, "little")
    assert frame == header + b"vin\r"
    assert encode("P", port=3, payload=b"x")[:2] == b"P\x03"


def test_decode_gives_back_each_frame_of_a_stream():
    stream = encode("h", t=7, payload=b"ok\r\n") + encode("y", t=9) \
        + encode("d", t=9, port=2, payload=b"\x01\x02\x01")
    assert [(f.kind, f.port, f.t, f.payload) for f in decode(stream)] == [
        ("h", 0, 7, b"ok\r\n"), ("y", 0, 9, b""), ("d", 2, 9, b"\x01\x02\x01")]


def test_a_payload_longer_than_the_length_field_is_refused():
    with pytest.raises(ValueError, match="too long"):
        encode("H", payload=bytes(0x10000))
    assert len(encode("H", payload=bytes(0xFFFF))) == HEADER.size + 0xFFFF


def test_the_c_end_has_the_same_header_fields_in_the_same_order():
    source = (REPO / "sil" / "standin" / "frame_transport.c").read_text(encoding="utf-8")
    body = re.search(r"struct header \{(.*?)\};", source, re.S)
    assert body is not None
    types = [kind for kind, names in re.findall(r"(uint\d+_t)\s+([\w\s,]+);", body.group(1))
             for _name in names.split(",")]
    assert types == ["uint8_t", "uint8_t", "uint16_t", "uint32_t", "uint64_t"] and HEADER.size == 16
