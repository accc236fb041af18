"""Firmware images the emulator's bootloader takes as a given release (its checksum), and the files
`buildhat-conformance load` reads, for the firmware-load tests in any folder."""
from __future__ import annotations

import pathlib
from typing import Tuple

from buildhat_conformance.protocol.image_checksum import image_with_checksum
from buildhat_conformance.protocol.profiles import get_profile


def image_of(release: str, size: int = 600) -> bytes:
    """``size`` bytes that the emulator's bootloader takes for ``release`` (its checksum)."""
    return image_with_checksum(size, get_profile(release).image_checksum)


def files(tmp_path: pathlib.Path, image: bytes, signature: bytes = bytes(64)) -> Tuple[str, str]:
    img, sig = tmp_path / "firmware.bin", tmp_path / "signature.bin"
    img.write_bytes(image)
    sig.write_bytes(signature)
    return str(img), str(sig)
