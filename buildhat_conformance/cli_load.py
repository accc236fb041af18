"""``buildhat-conformance load --target URL IMAGE SIGNATURE``: load a firmware image through the
HAT's bootloader (FIRMWARE-BEHAVIOUR.md#fb-bootloader) and confirm it runs.

Exit status: 0 loaded and running; 2 a file is missing or unreadable, or the bootloader refuses
it (image too large, signature length, signature that does not verify); 3 the target is
unreachable or faulted (silent, bytes lost on the link: checksum failure or data timeout, a HAT
running firmware that cannot be reset, firmware that does not start).
"""
# The folders install under this package's name (setup.py); pyright reads the checkout, where they
# sit beside this folder.
# pyright: reportMissingImports=false
from __future__ import annotations

import argparse
import sys

from .harness.bootloader.errors import LoadError
from .harness.bootloader.files import load_files
from .plumbing.cli_options import add_hidden_alias

__all__ = ["add_arguments", "main"]

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


def main(args: argparse.Namespace) -> int:
    try:
        result = load_files(args.target, args.image, args.signature, args.transcript)
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
    from .plumbing.cli_options import OneLineParser

    parser = OneLineParser(prog=PROG)
    add_arguments(parser)
    sys.exit(main(parser.parse_args()))
