"""The bootloader's image checksum (FIRMWARE-FACTS §9): computed by the host for ``load``,
checked by the bootloader (and by the emulator's bootloader)."""
from __future__ import annotations

__all__ = ["bootloader_checksum"]

_POLY = 0x1D872B41


def bootloader_checksum(data: bytes, state: int = 1) -> int:
    """§9: s starts at 1; per byte s = (s << 1) ^ (0x1D872B41 if the old top bit was 1), s ^= byte."""
    s = state
    for b in data:
        top = s >> 31
        s = (s << 1) & 0xFFFFFFFF
        if top:
            s ^= _POLY
        s ^= b
    return s
