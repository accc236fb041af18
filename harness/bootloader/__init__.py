"""Firmware load through the HAT's bootloader and HAT reset (FIRMWARE-BEHAVIOUR.md#fb-bootloader).

- :func:`read_firmware` (image + signature files) -> :class:`FirmwareImage`
- :func:`load_firmware` (open target, image) -> :class:`LoadResult`; raises :class:`LoadError`
  with one line and ``exit_status`` 2 (the files) or 3 (the target)
- :func:`reset_hat` / :func:`can_reset`: reset through the target's control (emulator channel,
  or :class:`GpioReset` for ``?reset=gpio`` on a Raspberry Pi)
"""
from __future__ import annotations

from .errors import EXIT_TARGET, EXIT_USAGE, LoadError
from .image import FirmwareImage, read_firmware
from .load import LoadResult, can_reset, load_firmware, reset_hat

__all__ = ["FirmwareImage", "read_firmware", "LoadResult", "load_firmware", "reset_hat", "can_reset",
           "LoadError", "EXIT_USAGE", "EXIT_TARGET"]
