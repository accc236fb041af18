"""LPF2 (LEGO UART protocol) messages between the HAT and a device (FIRMWARE-BEHAVIOUR.md#fb-device-messages).

Two directions share one wire format (type byte, optional command byte, payload, checksum):

- HAT -> device: :func:`hat_frame` applies the firmware's framing rules (length bits rewritten,
  zero padding to 2^L, checksum), used by write1/write2, combi, SELECT, SPEED and the keep-alives.
- device -> HAT: :func:`device_message` builds what a device sends during setup and data, and
  :class:`Assembler` turns a byte stream (either direction) back into :class:`Message` objects.

Type byte fields: bits 7-6 class, 5-3 log2 of the payload length, 2-0 mode or command.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Iterable, List, Optional, Sequence

__all__ = ["SYS", "CMD", "INFO", "DATA", "SYNC", "NACK", "ACK", "CMD_TYPE", "CMD_MODES",
           "CMD_SPEED", "CMD_SELECT", "CMD_WRITE", "CMD_EXT_MODE", "CMD_VERSION",
           "INFO_NAME", "INFO_RAW", "INFO_PCT", "INFO_SI", "INFO_SYMBOL", "INFO_MAPPING",
           "INFO_COMBI", "INFO_SPEED_PID", "INFO_POS_PID", "INFO_FORMAT", "INFO_MODE_PLUS_8",
           "MAX_PAYLOAD", "checksum", "length_code", "hat_frame", "select_frames",
           "combi_frame", "speed_frame", "device_message", "info_message", "Message",
           "Assembler"]

# Message classes (bits 7-6 of the type byte).
SYS, CMD, INFO, DATA = 0x00, 0x40, 0x80, 0xC0
# System bytes.
SYNC, NACK, ACK = 0x00, 0x02, 0x04
PRG = 0x05
# Commands (bits 2-0 of a CMD type byte).
CMD_TYPE, CMD_MODES, CMD_SPEED, CMD_SELECT, CMD_WRITE = 0, 1, 2, 3, 4
CMD_EXT_MODE, CMD_VERSION = 6, 7
# INFO command bytes the HAT parses (#fb-lpf2-receive).
INFO_NAME, INFO_RAW, INFO_PCT, INFO_SI, INFO_SYMBOL = 0x00, 0x01, 0x02, 0x03, 0x04
INFO_MAPPING, INFO_COMBI, INFO_SPEED_PID, INFO_POS_PID = 0x05, 0x06, 0x09, 0x0A
INFO_FORMAT = 0x80
INFO_MODE_PLUS_8 = 0x20   # bit 5 of the INFO command byte adds 8 to the 3-bit mode

MAX_PAYLOAD = 128         # the HAT clamps what it sends; LPF2 itself allows 2^7


def checksum(data: Iterable[int]) -> int:
    """0xFF XOR every byte: the value that makes the XOR of the whole message 0xFF."""
    c = 0xFF
    for b in data:
        c ^= b
    return c


def length_code(n: int) -> int:
    """L = the smallest k in 0..7 with 2^k >= n (n = 0 gives 0)."""
    k = 0
    while (1 << k) < n and k < 7:
        k += 1
    return k


def hat_frame(b0: int, payload: Sequence[int] = (), b1: Optional[int] = None) -> bytes:
    """A message as the HAT's sender frames it (#fb-framing).

    The payload is clamped to 128 bytes; the header's length bits are replaced by L, the
    type and mode bits kept; the optional second byte follows the header; the payload is
    zero-padded to 2^L bytes (so an empty payload still gets one pad byte).
    """
    body = bytes(b & 0xFF for b in payload)[:MAX_PAYLOAD]
    L = length_code(len(body))
    out = bytearray([(b0 & 0xC7) | (L << 3)])
    if b1 is not None:
        out.append(b1 & 0xFF)
    out += body + bytes((1 << L) - len(body))
    out.append(checksum(out))
    return bytes(out)


def select_frames(mode: int) -> List[bytes]:
    """``device_sendselect``: EXT_MODE with the mode's bit 3, then SELECT with bits 0-2."""
    return [hat_frame(CMD | CMD_EXT_MODE, [mode & 8]), hat_frame(CMD | CMD_SELECT, [mode & 7])]


def combi_frame(index: int, pairs: Sequence[tuple[int, int]]) -> bytes:
    """``combi <i> m1 d1 ...``: CMD WRITE (0x44) with [0x20 + n, i, (m << 4) | d ...]."""
    payload = [0x20 + len(pairs), index] + [((m & 0x0F) << 4) | (d & 0x0F) for m, d in pairs]
    return hat_frame(CMD | CMD_WRITE, payload)


def speed_frame(baud: int) -> bytes:
    """SPEED with the baud rate as 4 little-endian bytes (115200 -> ``52 00 C2 01 00 6E``)."""
    return hat_frame(CMD | CMD_SPEED, struct.pack("<I", baud & 0xFFFFFFFF))


def _padded(payload: bytes) -> tuple[int, bytes]:
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"LPF2 payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    L = length_code(len(payload))
    return L, payload + bytes((1 << L) - len(payload))


def device_message(msg_class: int, code: int, payload: bytes) -> bytes:
    """A CMD or DATA message as a device sends it: payload padded to 2^L, checksum added.

    ``code`` is the command (CMD) or the 3-bit mode (DATA).
    """
    if msg_class not in (CMD, DATA):
        raise ValueError("device_message builds CMD or DATA messages; use info_message for INFO")
    L, body = _padded(bytes(payload))
    out = bytes([msg_class | (L << 3) | (code & 7)]) + body
    return out + bytes([checksum(out)])


def info_message(mode: int, info: int, payload: bytes) -> bytes:
    """An INFO message for ``mode`` (0..15): modes 8..15 set bit 5 of the command byte."""
    if not 0 <= mode <= 15:
        raise ValueError(f"mode must be 0..15, got {mode}")
    L, body = _padded(bytes(payload))
    cmd = info | (INFO_MODE_PLUS_8 if mode >= 8 else 0)
    out = bytes([INFO | (L << 3) | (mode & 7), cmd]) + body
    return out + bytes([checksum(out)])


@dataclass(frozen=True)
class Message:
    """One received message. ``cmd`` is the INFO command byte (None for other classes)."""

    header: int
    payload: bytes
    raw: bytes
    cmd: Optional[int] = None
    ok: bool = True          # checksum correct

    @property
    def msg_class(self) -> int:
        return self.header & 0xC0

    @property
    def code(self) -> int:
        """Bits 2-0: the command of a CMD or SYS message, the mode of DATA/INFO."""
        return self.header & 7

    @property
    def mode(self) -> int:
        """The mode a DATA or INFO message is about (INFO: +8 when cmd bit 5 is set)."""
        extra = 8 if self.cmd is not None and self.cmd & INFO_MODE_PLUS_8 else 0
        return (self.header & 7) + extra

    @property
    def info(self) -> Optional[int]:
        """The INFO type with the +8 mode bit removed (None unless INFO)."""
        return None if self.cmd is None else self.cmd & ~INFO_MODE_PLUS_8 & 0xFF

    def hex(self) -> str:
        return self.raw.hex(" ").upper()


class Assembler:
    """Byte-at-a-time message parser (both directions use the same wire format).

    ``feed(b)`` returns a :class:`Message` when ``b`` completes one, else None. System bytes:
    ACK completes a message by itself; PRG takes a command byte and payload; SYNC, NACK and the
    other system bytes are ignored (they complete nothing) unless ``keep_system`` is set, as a
    device needs to see the HAT's NACK keep-alive. ``state`` names what the next byte is ("t"
    type, "c" command byte, "p" payload or checksum), which the HAT's debug trace shows.
    """

    def __init__(self, keep_system: bool = False) -> None:
        self.keep_system = keep_system
        self.reset()

    def reset(self) -> None:
        self._buf = bytearray()
        self._need = 0
        self._has_cmd = False
        self.state = "t"

    def feed(self, b: int) -> Optional[Message]:
        b &= 0xFF
        if not self._buf:
            cls = b & 0xC0
            if cls == SYS:
                code = b & 7
                if b == ACK or (self.keep_system and code != PRG):
                    return Message(header=b, payload=b"", raw=bytes([b]))
                if code != PRG:
                    return None
            self._buf.append(b)
            self._has_cmd = cls == INFO or (cls == SYS and (b & 7) == PRG)
            # payload + checksum (+ the command byte for INFO/PRG)
            self._need = (1 << ((b >> 3) & 7)) + 1 + (1 if self._has_cmd else 0)
            self.state = "c" if self._has_cmd else "p"
            return None
        self._buf.append(b)
        self._need -= 1
        self.state = "p"
        if self._need > 0:
            return None
        raw = bytes(self._buf)
        self.reset()
        start = 2 if self._has_cmd_of(raw) else 1
        return Message(header=raw[0], payload=raw[start:-1], raw=raw,
                       cmd=raw[1] if raw[0] & 0xC0 == INFO else None,
                       ok=checksum(raw[:-1]) == raw[-1])

    @staticmethod
    def _has_cmd_of(raw: bytes) -> bool:
        cls = raw[0] & 0xC0
        return cls == INFO or (cls == SYS and (raw[0] & 7) == PRG)


def parse_all(data: bytes) -> List[Message]:
    """Every complete message in ``data`` (a convenience for tests and tools)."""
    asm = Assembler()
    out = []
    for b in data:
        m = asm.feed(b)
        if m is not None:
            out.append(m)
    return out


__all__.append("parse_all")
