"""Load a firmware image into a HAT through its bootloader, then confirm it runs
(FIRMWARE-BEHAVIOUR.md#fb-bootloader).

:func:`load_firmware` on an open target: find out what answers; if it is the firmware, reset
the HAT into its bootloader where the target can (``reset_hat``: the emulator's control
channel, or ``?reset=gpio`` on a Raspberry Pi), else say how in one line; ``clear``; the image
(``load``), the signature; ``reboot``; wait for the firmware's start-up; ``version``.
:func:`reset_hat` is the one entry point for a reset, for ``run`` too (recovering a dead HAT).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Optional, TextIO

from ..targets.base import Target, TargetError
from ..transcript import TranscriptWriter
from .client import WIRE_BAUD, BootloaderClient, wire_seconds
from .errors import EXIT_TARGET, LoadError
from .image import FirmwareImage
from .progress import Progress
from .wire import Wire

__all__ = ["LoadResult", "load_firmware", "reset_hat", "can_reset", "wire_baud_of"]


@dataclass
class LoadResult:
    bootloader_version: str
    firmware_version: str         # what ``version`` says after the reboot (after "Firmware version: ")
    reset: bool                   # the HAT had to be reset into its bootloader first
    upload_seconds: float         # STX .. the bootloader's checksum answer
    wire_minimum_seconds: float   # the least time the image's bytes take at the wire's baud rate
    total_seconds: float


def can_reset(target: Target) -> bool:
    """Whether :func:`reset_hat` can work on this target."""
    return target.control is not None and target.has("reset")


def reset_hat(target: Target, bootloader: bool = True) -> None:
    """Reset the HAT behind ``target`` (its control: the emulator's channel, or GPIO on a Pi).
    A real HAT always restarts in its bootloader; the emulator restarts its firmware unless
    ``bootloader``. Raises TargetError (NeedsCapability) when the target cannot."""
    target.require("reset")
    assert target.control is not None
    target.control.reset(bootloader)


def wire_baud_of(target: Target) -> int:
    """The baud rate uploads are paced at: the target's own (a serial port's, an emulator's
    ``?baud=``), else the HAT's 115200."""
    for attr in ("wire_baud", "baudrate"):
        value = getattr(target, attr, None)
        if isinstance(value, int) and value > 0:
            return value
    return WIRE_BAUD


def load_firmware(target: Target, fw: FirmwareImage, transcript: Optional[TranscriptWriter] = None,
                  progress_stream: Optional[TextIO] = None, tty: Optional[bool] = None,
                  log: Callable[[str], None] = lambda _text: None, baud: Optional[int] = None) -> LoadResult:
    """Load ``fw`` through the bootloader of the (open) ``target`` and confirm it runs.
    Raises :class:`LoadError` (one line, ``exit_status`` 2 or 3)."""
    started = time.monotonic()
    wire = Wire(target, transcript)
    rate = baud or wire_baud_of(target)

    def bar(total: int, label: str) -> Progress:
        return Progress(total, label, stream=progress_stream, tty=tty)

    client = BootloaderClient(wire, baud=rate, progress=bar)
    kind, version = client.identify()
    was_reset = False
    if kind == "firmware":
        if not can_reset(target):
            raise LoadError(f"{target.url} runs firmware ({version}), not its bootloader, and this target "
                            "cannot reset the HAT: power-cycle the HAT (it starts in its bootloader) or, "
                            f"{target.reset_hint}, then retry",
                            EXIT_TARGET)
        log(f"{target.url} runs firmware {version}; resetting it into its bootloader")
        try:
            reset_hat(target, bootloader=True)
        except TargetError as exc:
            raise LoadError(" ".join(f"reset failed: {exc}".split()), EXIT_TARGET) from None
        was_reset = True
        kind, version = client.identify()
        if kind != "bootloader":
            raise LoadError(f"{target.url} still runs firmware ({version}) after a reset; is BOOT0 wired "
                            "and held low (docs/LAB.md)?", EXIT_TARGET)
    log(f"bootloader version {version}; loading {fw.describe()}")
    bootloader_version = version
    client.clear()
    up = time.monotonic()
    client.upload_image(fw)
    upload_seconds = time.monotonic() - up
    client.upload_signature(fw)
    client.reboot()
    client.wait_started()
    running = client.confirm()
    expected = fw.release
    if expected is not None and running.split()[:1] != [str(expected.number)]:
        raise LoadError(f"the HAT runs firmware {running} after loading {expected.name} "
                        f"({expected.number})", EXIT_TARGET)
    return LoadResult(bootloader_version, running, was_reset, upload_seconds,
                      wire_seconds(len(fw.image) + 2, rate), time.monotonic() - started)
