"""``buildhat-conformance load --target URL IMAGE SIGNATURE``: load a firmware image through the
HAT's bootloader (FIRMWARE-BEHAVIOUR.md#fb-bootloader) and confirm it runs.

Exit status: 0 loaded and running; 2 a file is missing or unreadable, or the bootloader refuses
it (image too large, signature length, signature that does not verify); 3 the target is
unreachable or faulted (silent, bytes lost on the link: checksum failure or data timeout, a HAT
running firmware that cannot be reset, firmware that does not start).
"""
from __future__ import annotations

import argparse
import sys
from typing import Optional

from ..cli_options import UsageError, add_hidden_alias
from ..preflight import checked_target
from ..targets.base import TargetError
from ..transcript import TranscriptWriter
from .errors import EXIT_TARGET, EXIT_USAGE, LoadError
from .image import read_firmware
from .load import LoadResult, load_firmware

__all__ = ["add_arguments", "main", "load_from_args"]

PROG = "buildhat-conformance load"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (__doc__ or "").split("\n\n")[0].replace("``", "'")   # plain text in --help
    parser.add_argument("-t", "--target", metavar="URL", default="emulator:?bootloader=1",
                        help="target URL: a serial port (add ?reset=gpio on a Raspberry Pi to reset the HAT "
                             "into its bootloader), socket://, cmd:..., emulator:?bootloader=1 (default)")
    parser.add_argument("-o", "--output", dest="transcript", default=None, metavar="FILE",
                        help="write every byte both ways to this JSONL transcript")
    add_hidden_alias(parser, "--transcript", dest="transcript")
    parser.add_argument("image",
                        help="the firmware image (e.g. buildhat/data/firmware.bin of python-build-hat)")
    parser.add_argument("signature", help="its 64-byte signature (buildhat/data/signature.bin)")


def load_from_args(url: str, image: str, signature: str, transcript: Optional[str] = None,
                   out=None) -> LoadResult:
    """Read the files, open the target, load, close. Raises LoadError (one line + exit status)."""
    out = out if out is not None else sys.stdout
    fw = read_firmware(image, signature)
    try:
        target = checked_target(url)     # the pre-flight every sub-command shares
    except UsageError as exc:
        raise LoadError(str(exc), EXIT_USAGE) from None
    except TargetError as exc:
        raise LoadError(" ".join(str(exc).split()), EXIT_TARGET) from None
    writer = TranscriptWriter(transcript, {"target": url, "tool": PROG}) if transcript else None
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


def main(args: argparse.Namespace) -> int:
    try:
        result = load_from_args(args.target, args.image, args.signature, args.transcript)
    except LoadError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return exc.exit_status
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; the HAT is left in its bootloader or mid-upload (run load again)",
              file=sys.stderr)
        return 130
    print(f"loaded: firmware version {result.firmware_version} "
          f"(upload {result.upload_seconds:.2f} s, wire minimum {result.wire_minimum_seconds:.2f} s)")
    return 0


if __name__ == "__main__":  # pragma: no cover
    from ..cli_options import OneLineParser

    parser = OneLineParser(prog=PROG)
    add_arguments(parser)
    sys.exit(main(parser.parse_args()))
