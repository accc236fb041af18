"""LPF2 framing (FIRMWARE-FACTS §8): every example byte-exact, and the receive-side parser.

Expected bytes are quoted from §8 ("Examples", "combi", "SELECT", "Link management").
"""
from __future__ import annotations

import pytest

from buildhat_conformance.emulator.ports import lpf2


def hx(s: str) -> bytes:
    return bytes.fromhex(s)


@pytest.mark.parametrize("b0,payload,b1,expected", [
    (0xC5, [0x10, 0x20, 0x30, 0x40], None, "D5 10 20 30 40 6A"),          # write1 c5 10 20 30 40
    (0xC0, [0x05], None, "C0 05 3A"),                                    # write1 c0 5
    (0x40, [], None, "40 00 BF"),                                        # write1 40
    (0x44, [0x22], 0x11, "44 11 22 88"),                                 # write2 44 11 22
    (0xC2, [0x12, 0x23, 0x34, 0x45, 0x12, 0x23, 0x34, 0x45, 0x12], None,
     "E2 12 23 34 45 12 23 34 45 12 00 00 00 00 00 00 00 0F"),
])
def test_hat_frame_examples(b0, payload, b1, expected):
    assert lpf2.hat_frame(b0, payload, b1) == hx(expected)


def test_combi_examples():
    assert lpf2.combi_frame(0, [(1, 0), (2, 0), (3, 0)]) == hx("5C 23 00 10 20 30 00 00 00 80")
    assert lpf2.combi_frame(0, []) == hx("4C 20 00 93")
    # combi 9 16 17 -> payload 21 07 FF after clamping (index 7, mode 15, dataset 15)
    frame = lpf2.combi_frame(7, [(15, 15)])
    assert frame[1:4] == hx("21 07 FF")


def test_select_and_speed_examples():
    assert lpf2.select_frames(0) == [hx("46 00 B9"), hx("43 00 BC")]
    assert lpf2.select_frames(9) == [hx("46 08 B1"), hx("43 01 BD")]
    assert lpf2.speed_frame(115200) == hx("52 00 C2 01 00 6E")


def test_length_bits_replaced_and_payload_clamped():
    # The caller's length bits are replaced; type and mode bits kept.
    assert lpf2.hat_frame(0xFF, [1])[0] == 0xC7
    frame = lpf2.hat_frame(0xC0, list(range(200)))
    assert len(frame) == 1 + 128 + 1          # maximum frame without b1: 130 bytes
    assert frame[0] == 0xC0 | (7 << 3)
    checks = 0
    for b in frame:
        checks ^= b
    assert checks == 0xFF                     # the XOR of the whole message is 0xFF


def test_length_code():
    assert [lpf2.length_code(n) for n in (0, 1, 2, 3, 4, 5, 8, 9, 32, 33, 128)] == \
        [0, 0, 1, 2, 2, 3, 3, 4, 5, 6, 7]


def test_device_messages_parse_back():
    # INFO for mode 9: bit 5 of the command byte adds 8 to the 3-bit mode.
    raw = lpf2.info_message(9, lpf2.INFO_NAME, b"DEBUG")
    assert raw[0] == 0x80 | (3 << 3) | 1 and raw[1] == 0x20
    (msg,) = lpf2.parse_all(raw)
    assert msg.ok and msg.mode == 9 and msg.info == lpf2.INFO_NAME
    assert msg.payload == b"DEBUG\x00\x00\x00"
    # DATA message of the 0x30 capture (DEVICES.md observed data): d8 00 00000000 ffff 00
    body = hx("D8 00 00 00 00 00 FF FF 00")
    data = lpf2.device_message(lpf2.DATA, 0, body[1:])
    assert data[:-1] == body
    (msg,) = lpf2.parse_all(data)
    assert msg.ok and msg.msg_class == lpf2.DATA and msg.mode == 0


def test_assembler_system_bytes_and_checksum_errors():
    stream = hx("00 02 04") + hx("C0 05 00")           # SYNC, NACK ignored; ACK; bad checksum
    msgs = lpf2.parse_all(stream)
    assert [m.header for m in msgs] == [0x04, 0xC0]
    assert msgs[0].ok and not msgs[1].ok
    # A device-side parser keeps NACK (the keep-alive it answers).
    asm = lpf2.Assembler(keep_system=True)
    assert asm.feed(0x02).header == 0x02


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError):
        lpf2.info_message(16, lpf2.INFO_NAME, b"X")
    with pytest.raises(ValueError):
        lpf2.device_message(lpf2.DATA, 0, bytes(129))
    with pytest.raises(ValueError):
        lpf2.device_message(lpf2.INFO, 0, b"x")
