"""The bootloader's image checksum (FIRMWARE-BEHAVIOUR.md#fb-image-checksum): computed by the host
for ``load``, checked by the bootloader (and by the emulator's bootloader)."""
from __future__ import annotations

__all__ = ["bootloader_checksum", "image_with_checksum"]

_POLY = 0x1D872B41


def bootloader_checksum(data: bytes, state: int = 1) -> int:
    """#fb-image-checksum: s starts at 1; per byte s = (s << 1) ^ (0x1D872B41 if the old top bit was 1),
    s ^= byte."""
    s = state
    for b in data:
        top = s >> 31
        s = (s << 1) & 0xFFFFFFFF
        if top:
            s ^= _POLY
        s ^= b
    return s


def image_with_checksum(size: int, checksum: int) -> bytes:
    """``size`` filler bytes whose checksum is ``checksum`` (a release's, from profiles.json): the
    emulator's bootloader then starts that release, as a HAT would with the real image (tests,
    ``make bench``). The checksum is linear over GF(2) in the data, so the low bits of the last
    32 bytes (0 or 1 each) reach any value."""
    if size < 32:
        raise ValueError(f"an image with a chosen checksum needs at least 32 bytes, not {size}")
    prefix = bytes((7 * i + 3) & 0xFF for i in range(size - 32))
    bits = bootloader_checksum(prefix + bytes(32)) ^ checksum
    return prefix + bytes((bits >> (31 - j)) & 1 for j in range(32))
