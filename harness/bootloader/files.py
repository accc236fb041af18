"""A firmware image and its signature, from their files onto the HAT at a target URL: what
``buildhat-conformance load`` and ``run --image`` do (harness/bootloader/load.py does the loading)."""
from __future__ import annotations

import sys
from typing import Optional, TextIO

from ...plumbing.cli_options import UsageError
from ..preflight import checked_target
from ..targets.base import TargetError
from ..transcript import TranscriptWriter
from .errors import EXIT_TARGET, EXIT_USAGE, LoadError
from .image import read_firmware
from .load import LoadResult, load_firmware

__all__ = ["load_files"]


def load_files(url: str, image: str, signature: str, transcript: Optional[str] = None,
               out: Optional[TextIO] = None) -> LoadResult:
    """Read the files, open the target, load, close. Raises LoadError (one line + exit status)."""
    out = out if out is not None else sys.stdout
    fw = read_firmware(image, signature)
    try:
        target = checked_target(url)     # the pre-flight every sub-command shares
    except UsageError as exc:
        raise LoadError(str(exc), EXIT_USAGE) from None
    except TargetError as exc:
        raise LoadError(" ".join(str(exc).split()), EXIT_TARGET) from None
    writer = TranscriptWriter(transcript, {"target": url,
                                           "tool": "buildhat-conformance load"}) if transcript else None
    try:
        try:
            target.open()
        except TargetError as exc:
            raise LoadError(" ".join(str(exc).split()), EXIT_TARGET) from None
        return load_firmware(target, fw, transcript=writer,
                             log=lambda text: print(text, file=out, flush=True))
    finally:
        target.close()
        if writer is not None:
            writer.close()
