"""``buildhat-conformance rp2040 setup``: install what the ``rp2040:`` target needs beside Python.

Installs the pinned rp2040js with npm into the project's cache (once; nothing goes into the
package) and says where the boot ROM is looked for. ``rp2040 check URL`` says in one line whether
a target URL would start (image, ROM, Node.js, rp2040js).
"""
from __future__ import annotations

import argparse
import sys

from ..harness.targets.base import TargetError
from ..plumbing.cli_options import EXIT_TARGET
from .install import BOOTROM_ENV, RP2040JS_VERSION, default_bootrom, install_rp2040js, node_program

__all__ = ["add_arguments", "main"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="rp2040_command", metavar="ACTION")
    sub.add_parser("setup", help=f"install rp2040js {RP2040JS_VERSION} into the cache with npm (once)",
                   description="Install the pinned rp2040js (the RP2040 emulator, npm, MIT) into "
                               "~/.cache/buildhat-conformance/rp2040js with npm, for rp2040: targets.")
    check = sub.add_parser("check", help="say whether an rp2040: target URL would start")
    check.add_argument("url", metavar="URL", help="e.g. rp2040:R7 or rp2040:path/to/firmware.bin")


def main(args: argparse.Namespace) -> int:
    from ..plumbing.cli_options import UsageError
    if args.rp2040_command is None:
        raise UsageError("rp2040 needs an action: rp2040 setup, or rp2040 check URL")
    if args.rp2040_command == "check":
        from .target import from_url
        try:
            target = from_url(args.url)
        except TargetError as exc:
            print(f"buildhat-conformance rp2040: {str(exc).removeprefix('rp2040: ')}", file=sys.stderr)
            return EXIT_TARGET
        print(f"ok: {target.image.path} (release {target.image.release}) with the boot ROM {target.bootrom}")
        return 0
    try:
        node_program()
        folder = install_rp2040js()
    except (TargetError, RuntimeError) as exc:
        print(f"buildhat-conformance rp2040: {str(exc).removeprefix('rp2040: ')}", file=sys.stderr)
        return EXIT_TARGET
    print(f"rp2040js {RP2040JS_VERSION} is in {folder}; the boot ROM is read from ?bootrom=FILE, "
          f"${BOOTROM_ENV} or {default_bootrom()}")
    return 0
