"""``list``: the device dump of one port (FIRMWARE-BEHAVIOUR.md#fb-list), rendered from the HAT's parsed
record of the device (emulator/devices/info.py), never from the catalogue.

Rules that matter: the port is one hex digit; ranges are floats printed as unsigned 32-bit
integers with the RP2040's saturating conversion (negative -> 00000000, >= 2^32 -> FFFFFFFF,
otherwise truncation); ``SI = `` keeps its trailing space when the symbol is empty; one
``C<i>:`` line per non-zero combi mask; both PID lines always, zeros when none were sent.
"""
from __future__ import annotations

import math
from typing import List, Optional

from ..devices.info import DeviceInfo

__all__ = ["float_to_uint", "active_dump", "passive_line", "empty_line", "combi_text"]


def float_to_uint(x: float) -> int:
    """The RP2040 ROM ``float_to_uint``: truncate toward zero, saturate at 0 and 2^32-1."""
    if math.isnan(x) or x <= 0:
        return 0
    if x >= 4294967296.0:
        return 0xFFFFFFFF
    return int(x)


def _hex(x: float) -> str:
    return f"{float_to_uint(x):08X}"


def combi_text(mask: int) -> str:
    """``M1+M2+M3`` for mask 0b1110: the set bits, low to high."""
    return "+".join(f"M{bit}" for bit in range(16) if mask >> bit & 1)


def empty_line(port: int) -> str:
    return f"P{port:X}: no device detected"


def passive_line(port: int, passive_id: int) -> str:
    return f"P{port:X}: connected to passive ID {passive_id}"


def active_dump(port: int, info: DeviceInfo) -> List[str]:
    """The lines ``list`` prints for an established active device (without CRLF)."""
    type_id: Optional[int] = info.type_id
    tid = f"{(type_id or 0) & 0xFF:02X}"
    lines = [
        f"P{port:X}: connected to active ID {tid}",
        f"type {tid}",
        f"  nmodes ={info.nmodes}",
        f"  nview  ={info.nview}",
        f"  baud   ={info.baud}",
        f"  hwver  ={info.hwver:08X}",
        f"  swver  ={info.swver:08X}",
    ]
    for index in range(16):
        mode = info.modes.get(index)
        if mode is None or not mode.name:
            continue
        lines += [
            f"  M{index} {mode.name} SI = {mode.symbol}",
            f"    format count={mode.count} type={mode.type} chars={mode.chars} dp={mode.dp}",
            f"    RAW: {_hex(mode.raw[0])} {_hex(mode.raw[1])}"
            f"    PCT: {_hex(mode.pct[0])} {_hex(mode.pct[1])}"
            f"    SI: {_hex(mode.si[0])} {_hex(mode.si[1])}",
        ]
    for i, mask in enumerate(info.combi_masks):
        if mask:
            lines.append(f"  C{i}: {combi_text(mask)}")
    lines.append("     speed PID:" + "".join(f" {w & 0xFFFFFFFF:08X}" for w in info.speed_pid))
    lines.append("  position PID:" + "".join(f" {w & 0xFFFFFFFF:08X}" for w in info.position_pid))
    return lines
