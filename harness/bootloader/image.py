"""A firmware image and its signature, read from files, as ``load`` sends them
(FIRMWARE-BEHAVIOUR.md#fb-bootloader-load).

The python-build-hat wheels bundle such a pair as ``buildhat/data/firmware.bin`` and
``signature.bin``. An image whose checksum is a release's (``protocol/profiles.json``) is
that release; the ``version`` line after the reboot must then name it.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Optional

from ...protocol.image_checksum import bootloader_checksum
from ...protocol.profiles import Profile, load_profiles
from .errors import EXIT_USAGE, LoadError

__all__ = ["FirmwareImage", "read_firmware"]


@dataclass(frozen=True)
class FirmwareImage:
    image: bytes
    signature: bytes
    image_path: str = ""
    signature_path: str = ""

    @property
    def checksum(self) -> int:
        return bootloader_checksum(self.image)

    @property
    def release(self) -> Optional[Profile]:
        """The release this image is (same checksum), or None for any other build."""
        checksum = self.checksum
        return next((p for p in load_profiles().values() if p.image_checksum == checksum), None)

    def describe(self) -> str:
        rel = self.release
        what = f"release {rel.name} ({rel.number})" if rel else "not a known release"
        return f"{len(self.image)} bytes, checksum {self.checksum}, {what}"


def _read(path: str, what: str) -> bytes:
    try:
        with open(path, "rb") as fh:
            return fh.read()
    except FileNotFoundError:
        raise LoadError(f"{what} {path!r}: no such file", EXIT_USAGE) from None
    except IsADirectoryError:
        raise LoadError(f"{what} {path!r} is a directory, not a file", EXIT_USAGE) from None
    except OSError as exc:
        raise LoadError(f"{what} {path!r}: cannot read it ({exc.strerror})", EXIT_USAGE) from None


def read_firmware(image_path: str, signature_path: str) -> FirmwareImage:
    """Both files, read whole. Their sizes are the bootloader's to judge (it says so in one line)."""
    image = _read(image_path, "image")
    signature = _read(signature_path, "signature")
    if not image:
        raise LoadError(f"image {image_path!r} is empty", EXIT_USAGE)
    return FirmwareImage(image, signature, os.fspath(image_path), os.fspath(signature_path))
