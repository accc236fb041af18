"""What the HAT learns about an active device from its setup messages (FIRMWARE-BEHAVIOUR.md#fb-lpf2-receive).

:class:`DeviceInfo` is the HAT's record of one device; :meth:`DeviceInfo.apply` takes one
received setup message. ``list`` (emulator/commands/listing.py) prints from this record only, so what it
shows is what the HAT parsed, never the catalogue. Setup messages the HAT does not parse are
reported back as "unknown" so the port can print the debug-32 lines.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Dict, List, Optional

from ..ports import lpf2

__all__ = ["ModeInfo", "DeviceInfo", "FORMAT_SIZES"]

# Bytes per value of a format type (0 int8, 1 int16, 2 int32, 3 float).
FORMAT_SIZES = {0: 1, 1: 2, 2: 4, 3: 4}


@dataclass
class ModeInfo:
    name: str = ""
    symbol: str = ""
    raw: tuple[float, float] = (0.0, 0.0)
    pct: tuple[float, float] = (0.0, 0.0)
    si: tuple[float, float] = (0.0, 0.0)
    mapping: tuple[int, int] = (0, 0)
    count: int = 0
    type: int = 0
    chars: int = 0
    dp: int = 0

    @property
    def value_size(self) -> int:
        return FORMAT_SIZES.get(self.type, 1)


def _cstring(payload: bytes) -> str:
    nul = payload.find(b"\x00")
    return (payload if nul < 0 else payload[:nul]).decode("latin-1")


def _floats(payload: bytes) -> tuple[float, float]:
    return struct.unpack("<ff", (payload + bytes(8))[:8])


def _words(payload: bytes) -> List[int]:
    return list(struct.unpack("<4I", (payload + bytes(16))[:16]))


@dataclass
class DeviceInfo:
    """The HAT's record of an active device (filled in while its setup messages arrive)."""

    type_id: Optional[int] = None
    nmodes: int = 0
    nview: int = 0
    baud: int = 0
    hwver: int = 0
    swver: int = 0
    modes: Dict[int, ModeInfo] = field(default_factory=dict)
    combi_masks: List[int] = field(default_factory=list)
    speed_pid: List[int] = field(default_factory=lambda: [0, 0, 0, 0])
    position_pid: List[int] = field(default_factory=lambda: [0, 0, 0, 0])

    def mode(self, index: int) -> ModeInfo:
        return self.modes.setdefault(index, ModeInfo())

    def apply(self, msg: lpf2.Message) -> bool:
        """Record one setup message; False if the HAT does not parse this kind (debug 32)."""
        p = msg.payload
        if msg.msg_class == lpf2.CMD:
            code = msg.code
            if code == lpf2.CMD_TYPE:
                self.type_id = p[0]
            elif code == lpf2.CMD_MODES:
                # The extended 4-byte form carries the real counts in bytes 2 and 3.
                if len(p) >= 4:
                    self.nmodes, self.nview = p[2], p[3]
                else:
                    self.nmodes, self.nview = p[0], p[1] if len(p) > 1 else 0
            elif code == lpf2.CMD_SPEED:
                self.baud = struct.unpack("<I", (p + bytes(4))[:4])[0]
            elif code == lpf2.CMD_VERSION:
                self.hwver, self.swver = struct.unpack("<II", (p + bytes(8))[:8])
            else:
                return False
            return True
        if msg.msg_class == lpf2.INFO:
            info, m = msg.info, msg.mode
            if info == lpf2.INFO_NAME:
                self.mode(m).name = _cstring(p)
            elif info == lpf2.INFO_RAW:
                self.mode(m).raw = _floats(p)
            elif info == lpf2.INFO_PCT:
                self.mode(m).pct = _floats(p)
            elif info == lpf2.INFO_SI:
                self.mode(m).si = _floats(p)
            elif info == lpf2.INFO_SYMBOL:
                self.mode(m).symbol = _cstring(p)
            elif info == lpf2.INFO_MAPPING:
                self.mode(m).mapping = (p[0], p[1] if len(p) > 1 else 0)
            elif info == lpf2.INFO_FORMAT:
                mi = self.mode(m)
                mi.count, mi.type, mi.chars, mi.dp = (p + bytes(4))[:4]
            elif info == lpf2.INFO_COMBI:
                self.combi_masks = [w for (w,) in struct.iter_unpack("<H", p[: len(p) // 2 * 2])]
            elif info == lpf2.INFO_SPEED_PID:
                self.speed_pid = _words(p)
            elif info == lpf2.INFO_POS_PID:
                self.position_pid = _words(p)
            else:
                return False
            return True
        return False
