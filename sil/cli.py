"""``buildhat-conformance sil``: the real firmware built for this host.

``sil build TREE [--sanitize address,undefined] [--coverage]`` compiles a firmware tree (a
``firmware-pico/`` folder or a checkout with one) against the project's stand-in and prints
one line: where the program is and the target URL (``sil:TREE`` with the options) that runs it;
and one more naming the tree's C files its CMakeLists.txt leaves out, if any. The build is cached.
Each action's ``--help`` ends with its own exit statuses (plumbing/cli_exits.py).
``sil coverage PROGRAM`` prints the firmware's line and branch coverage from the runs of a
program built with ``--coverage`` (``--reset`` clears it first, for one run's figure).
``sil mutate``, ``sil bisect``, ``sil history`` and their merges run the suite on many builds: they
are campaigns/cli.py's, added under ``sil`` by buildhat_conformance/cli_sil.py.
"""
from __future__ import annotations

import argparse
import sys
from typing import Any, Callable, Optional

from ..plumbing.cli_exits import exit_status_help
from ..plumbing.cli_options import UsageError
from .build import SANITIZERS, Build, BuildError, build_tree

__all__ = ["add_arguments", "main"]


def _sanitizers(text: str) -> list:
    names = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in names if s not in SANITIZERS]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown sanitizer {bad[0]!r} (known: {', '.join(SANITIZERS)})")
    return names


def _serve_help() -> str:
    """``sil serve``'s own help (its options are sil/serve.py's), ending with its exit statuses."""
    from .serve import build_parser as serve_parser
    parser = serve_parser()
    parser.epilog = " ".join(filter(None, [parser.epilog, exit_status_help("sil serve")]))
    return parser.format_help()


def add_arguments(parser: argparse.ArgumentParser,
                  more: Optional[Callable[[Any], None]] = None) -> None:
    """sil's own actions; ``more(sub)`` adds others in their place in the help (the campaigns:
    buildhat_conformance/cli_sil.py)."""
    sub = parser.add_subparsers(dest="sil_command", metavar="ACTION")
    build = sub.add_parser("build", help="build a firmware tree for this host (cached)",
                           description="Compile the C files a Build HAT firmware tree's CMakeLists.txt "
                                       "makes the firmware of (with its compile definitions and include "
                                       "folders; without one, every C file of the folder), unchanged, "
                                       "against the project's stand-in for the pico-sdk. The C files it "
                                       "leaves out are named.",
                           epilog=exit_status_help("sil build"))
    build.add_argument("tree", metavar="TREE", help="a firmware-pico/ folder, or a checkout containing one")
    build.add_argument("--sanitize", type=_sanitizers, default=[], metavar="LIST",
                       help="build with sanitizers: address, undefined (comma-separated)")
    build.add_argument("--coverage", action="store_true",
                       help="build with gcov coverage of the firmware's files")
    serve = sub.add_parser("serve", add_help=False,
                           help="serve a firmware at wall-clock pace on a pty/TCP/stdio "
                                "(see sil serve --help)")
    serve.add_argument("rest", nargs=argparse.REMAINDER)
    # its options are parsed by sil/serve.py; -h first (REMAINDER takes none) asks it for its help
    serve.add_argument("-h", "--help", dest="serve_help", action="store_true", help=argparse.SUPPRESS)
    if more is not None:
        more(sub)
    cov = sub.add_parser("coverage", help="the firmware's line and branch coverage (a --coverage build)",
                         description="The firmware's line and branch coverage from the runs of a tree "
                                     "built with --coverage (gcovr).",
                         epilog=exit_status_help("sil coverage"))
    cov.add_argument("tree", metavar="TREE", help="the firmware tree the build was made from")
    cov.add_argument("--sanitize", type=_sanitizers, default=[], metavar="LIST", help="as given to sil build")
    cov.add_argument("--reset", action="store_true", help="clear the counts (before a run)")
    cov.add_argument("--html", metavar="FILE", help="also write gcovr's HTML page of every line")


def main(args: argparse.Namespace) -> int:
    if args.sil_command is None:
        raise UsageError("sil needs an action: sil build TREE (see sil --help)")
    if args.sil_command == "serve":
        if args.serve_help or any(a in ("-h", "--help") for a in args.rest):
            print(_serve_help(), end="")
            return 0
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
        print(f"{what}: {build.tree}{extra} -> {build.program} (target: {target_url(build)})")
        for line in build.plan.said() if build.plan is not None else []:
            print(line)
        return 0
    from .firmware_coverage import coverage_summary, reset_counts
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


def target_url(build: Build) -> str:
    """The ``sil:`` URL that runs this build: the tree and the options it was built with."""
    options = ([f"sanitize={','.join(build.sanitize)}"] if build.sanitize else []) + \
        (["coverage=1"] if build.coverage else [])
    return f"sil:{build.tree}" + (f"?{'&'.join(options)}" if options else "")
