"""Frames between the world and the firmware (sil/frames.py), laid out by hand from the module's
documented header (type letter, port, payload length, 4 spare bytes, virtual ns; little-endian) and
checked against the C end's struct (sil/standin/frame_transport.c, our stand-in's code)."""
from __future__ import annotations

import re

import pytest
from repo_paths import REPO

from buildhat_conformance.sil.frames import HEADER, FrameType, decode, encode


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


# -- the frame types, named once in each language ------------------------------------------------

def _c_frame_types() -> dict:
    header = (REPO / "sil" / "standin" / "frame_types.h").read_text(encoding="utf-8")
    body = re.search(r"enum sil_frame_type \{(.*?)\};", header, re.S)
    assert body is not None, "frame_types.h has no enum sil_frame_type"
    pairs = re.findall(r"\bFRAME_(\w+)\s*=\s*'(.)'", body.group(1))
    assert len(pairs) == len(re.findall(r"=", body.group(1))), "an enum entry that is not FRAME_NAME = 'x'"
    return dict(pairs)


def _js_frame_types() -> dict:
    runner = (REPO / "rp2040" / "runner.mjs").read_text(encoding="utf-8")
    body = re.search(r"const FRAME = Object\.freeze\(\{(.*?)\}\);", runner, re.S)
    assert body is not None, "runner.mjs has no `const FRAME = Object.freeze({...});`"
    lines = [ln.strip() for ln in body.group(1).splitlines()]
    lines = [ln for ln in lines if ln and not ln.startswith("//")]
    pairs = [re.fullmatch(r"(\w+): '(.)',?", ln) for ln in lines]
    assert all(pairs), [ln for ln, m in zip(lines, pairs) if not m]
    return dict(m.groups() for m in pairs if m)


def test_the_frame_types_are_the_same_in_python_c_and_the_rp2040_runner():
    python = {t.name: t.value for t in FrameType}
    assert len(python) == 22 and len(set(python.values())) == len(python)
    assert _c_frame_types() == python
    assert _js_frame_types() == python


def test_the_ends_use_the_names_not_the_letters():
    # A bare letter where a frame type is meant is a second place that knows it.
    transport = (REPO / "sil" / "standin" / "frame_transport.c").read_text(encoding="utf-8")
    assert not re.findall(r"case '.'|emit\('.'", transport)
    runner = (REPO / "rp2040" / "runner.mjs").read_text(encoding="utf-8")
    assert not re.findall(r"case '.'|emit\('.'", runner)
    for module in ("process.py", "port_world.py", "hat.py"):
        source = (REPO / "sil" / module).read_text(encoding="utf-8")
        letters = r"""encode\(["'].["']|_until\(["'].["']|kind (?:==|in) \(?["'].["']"""
        assert not re.findall(letters, source), module
