"""Frames between the world (this package, Python) and a firmware built with the stand-in (C).

Both directions use one header, ``<BBHIQ``: type (one ASCII letter), port, payload length,
4 spare bytes, time in virtual nanoseconds; the payload follows. ``standin/frame_transport.c`` is
the other end. The firmware runs only between a run frame and the yield frame that answers it.
Each type is named once per language: :class:`FrameType` here, ``standin/frame_types.h`` in C,
``FRAME`` in ``rp2040/runner.mjs`` (tests/sil/test_frames.py checks that the three agree).

World -> firmware (upper case):

| type | port | time | payload | meaning |
|---|---|---|---|---|
| ``R`` | - | run limit | flags (bit 0: yield when the command port falls idle) | run |
| ``H`` | - | earliest start | bytes | bytes from the host on the command port (paced at its baud) |
| ``P`` | port | earliest start | baud (u32), bytes | bytes from the port's device |
| ``C`` | port | now | - | the device stopped sending: bytes not yet on the wire are dropped |
| ``I`` | port | - | signature (u16), RX line level when the device is idle (u8) | the device's ID lines |
| ``G`` | - | - | port-power OK (u8), motor-power OK (u8) | the two fault pins (1 = no fault) |
| ``F`` | port | - | 3 bytes | the port driver's fault registers 0x4D-0x4F |
| ``A`` | - | - | raw (u16) | the ADC reading of the input voltage |
| ``W`` | - | - | mask (u8, bit n: port n) | ports whose ``d`` stops the firmware (default: all) |
| ``S`` | - | - | 64 bytes | what the bootloader left at 0x2003FF00 (the image signature) |
| ``Q`` | - | - | - | exit (coverage data is written) |
| ``K`` | - | - | socket path, NUL, stderr path | fork a copy of this HAT, which connects to the socket |

The other ports' ``d`` frames wait, with their times, for the next stop. The rest byte of ``y``:
bit 0, nothing is leaving on the command port; bit 1, nothing from the host is arriving.

Firmware -> world (lower case):

| type | port | time | payload | meaning |
|---|---|---|---|---|
| ``y`` | - | now | ``SIL1`` on the first (a copy adds its pid, i32); then the port's rest (u8) | yield |
| ``k`` | - | now | the copy's pid (i32; negative: errno) | answer to ``K`` |
| ``h`` | - | end of the last byte | bytes | bytes to the host (one frame per stretch) |
| ``p`` | port | end of the byte | baud (u32), byte | a byte to the port's device |
| ``u`` | port | now | on (u8), baud (u32) | the port's receiver was switched on/off |
| ``d`` | port | now | duty (i16, -255..255), driven (u8; 0 = outputs off) | the motor driver's output |
| ``f`` | port | now | - | the driver's fault latch was cleared |
| ``o`` | - | now | on (u8) | port power switched |
| ``l`` | - | now | bits (u8) | the two status LEDs |
| ``r`` | port | arrival | the byte (u8) | a byte from the port's device was lost: the PIO RX FIFO was full |
"""
from __future__ import annotations

import struct
from enum import Enum
from typing import Iterator, NamedTuple

__all__ = ["HEADER", "HELLO", "Frame", "FrameType", "encode", "decode", "NS_PER_MS"]

HEADER = struct.Struct("<BBHIQ")
HELLO = b"SIL1"
NS_PER_MS = 1_000_000


class FrameType(str, Enum):
    """The frame types of the tables above, by name (each is its one-letter string)."""

    # world -> firmware
    RUN = "R"
    HOST_BYTES = "H"
    PORT_BYTES = "P"
    PORT_CUT = "C"
    ID_LINES = "I"
    FAULT_PINS = "G"
    FAULT_REGS = "F"
    ADC = "A"
    DRIVE_STOPS = "W"
    SIGNATURE = "S"
    QUIT = "Q"
    COPY = "K"
    # firmware -> world
    YIELD = "y"
    COPY_MADE = "k"
    TO_HOST = "h"
    TO_PORT = "p"
    RECEIVER = "u"
    DRIVE = "d"
    FAULTS_CLEARED = "f"
    POWER = "o"
    LEDS = "l"
    BYTE_LOST = "r"


class Frame(NamedTuple):
    kind: str       # a FrameType's letter (FrameType members compare equal to it)
    port: int
    t: int          # virtual ns
    payload: bytes


def encode(kind: str, t: int = 0, payload: bytes = b"", port: int = 0) -> bytes:
    if len(payload) > 0xFFFF:
        raise ValueError(f"frame payload too long ({len(payload)} bytes)")
    return HEADER.pack(ord(kind), port, len(payload), 0, max(0, int(t))) + payload


def decode(buf: bytes) -> Iterator[Frame]:
    """Every whole frame in ``buf`` (which must hold whole frames only)."""
    i, n, size = 0, len(buf), HEADER.size
    while i + size <= n:
        kind, port, length, _spare, t = HEADER.unpack_from(buf, i)
        i += size
        yield Frame(chr(kind), port, t, bytes(buf[i:i + length]))
        i += length
