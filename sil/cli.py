"""``buildhat-conformance sil``: the real firmware built for this host.

``sil build TREE [--sanitize address,undefined] [--coverage]`` compiles a firmware tree (a
``firmware-pico/`` folder or a checkout with one) against the project's stand-in and prints
one line: where the program is and the target URL that runs it. The build is cached.
``sil coverage PROGRAM`` prints the firmware's line and branch coverage from the runs of a
program built with ``--coverage`` (``--reset`` clears it first, for one run's figure).
"""
from __future__ import annotations

import argparse
import sys

from ..harness.cli_options import UsageError
from .build import SANITIZERS, BuildError, build_tree

__all__ = ["add_arguments", "main"]


def _sanitizers(text: str) -> list:
    names = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in names if s not in SANITIZERS]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown sanitizer {bad[0]!r} (known: {', '.join(SANITIZERS)})")
    return names


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="sil_command", metavar="ACTION")
    build = sub.add_parser("build", help="build a firmware tree for this host (cached)",
                           description="Compile every C file of a Build HAT firmware tree, unchanged, "
                                       "against the project's stand-in for the pico-sdk.")
    build.add_argument("tree", metavar="TREE", help="a firmware-pico/ folder, or a checkout containing one")
    build.add_argument("--sanitize", type=_sanitizers, default=[], metavar="LIST",
                       help="build with sanitizers: address, undefined (comma-separated)")
    build.add_argument("--coverage", action="store_true",
                       help="build with gcov coverage of the firmware's files")
    serve = sub.add_parser("serve", add_help=False,
                           help="serve a firmware at wall-clock pace on a pty/TCP/stdio "
                                "(see sil serve --help)")
    serve.add_argument("rest", nargs=argparse.REMAINDER)
    cov = sub.add_parser("coverage", help="the firmware's line and branch coverage (a --coverage build)")
    cov.add_argument("tree", metavar="TREE", help="the firmware tree the build was made from")
    cov.add_argument("--sanitize", type=_sanitizers, default=[], metavar="LIST", help="as given to sil build")
    cov.add_argument("--reset", action="store_true", help="clear the counts (before a run)")
    cov.add_argument("--html", metavar="FILE", help="also write gcovr's HTML page of every line")


def main(args: argparse.Namespace) -> int:
    if args.sil_command is None:
        raise UsageError("sil needs an action: sil build TREE (see sil --help)")
    if args.sil_command == "serve":
        from .serve import main as serve_main
        return serve_main(args.rest)
    try:
        build = build_tree(args.tree, sanitize=args.sanitize, coverage=getattr(args, "coverage", True)
                           if args.sil_command == "build" else True)
    except BuildError as exc:
        raise UsageError(str(exc)) from None
    if args.sil_command == "build":
        what = "up to date" if build.cached else "built"
        extra = "".join(f" +{s}" for s in build.sanitize) + (" +coverage" if build.coverage else "")
        print(f"{what}: {build.tree}{extra} -> {build.program} (target: sil:{build.program})")
        return 0
    from .coverage import coverage_summary, reset_counts
    if args.reset:
        reset_counts(build)
        print(f"coverage counts cleared: {build.folder}")
        return 0
    try:
        print(coverage_summary(build, html=args.html).text())
    except RuntimeError as exc:
        print(f"buildhat-conformance sil: {exc}", file=sys.stderr)
        return 2
    return 0
