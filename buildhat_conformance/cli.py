"""``buildhat-conformance``: one command, one sub-command per job.

Each sub-command lives in the package that owns it and provides two functions,
``add_arguments(parser)`` and ``main(args) -> int``; only the chosen one is imported.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from typing import Optional, Sequence

from . import __version__

SUBCOMMANDS = {
    "run": ("buildhat_conformance.conformance.runner", "run the conformance suite against a target"),
    "script": ("buildhat_conformance.harness.cli_script", "run one scenario script and write its transcript"),
    "targets": ("buildhat_conformance.harness.cli_targets", "list the targets this machine can see"),
    "fuzz": ("buildhat_conformance.fuzz.cli", "grammar-based and stateful fuzzing of a target"),
    "record": ("buildhat_conformance.harness.record", "record a scenario's transcript on a target"),
    "replay": ("buildhat_conformance.harness.replay", "replay a transcript against a target and diff"),
    "mock": ("buildhat_conformance.harness.mock", "serve a transcript as a fake HAT"),
    "report": ("buildhat_conformance.harness.report.cli", "build the HTML report from JUnit files"),
    "load": ("buildhat_conformance.harness.firmware.cli",
             "load a firmware image through the HAT's bootloader"),
    "bench": ("buildhat_conformance.bench.cli", "benchmarks: timing, throughput, fidelity"),
}


def build_parser() -> argparse.ArgumentParser:
    summary = (__doc__ or "").partition("\n")[0]          # no docstring under python -OO
    parser = argparse.ArgumentParser(prog="buildhat-conformance", description=summary)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (_module, help_text) in SUBCOMMANDS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in SUBCOMMANDS:
        build_parser().parse_args(argv or ["--help"])
        return 2
    name = argv[0]
    module_name, help_text = SUBCOMMANDS[name]
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and module_name.startswith(exc.name):
            print(f"buildhat-conformance: '{name}' is not available in this build ({exc.name})",
                  file=sys.stderr)
            return 2
        raise
    parser = argparse.ArgumentParser(prog=f"buildhat-conformance {name}", description=help_text)
    module.add_arguments(parser)
    if getattr(module, "PASS_UNKNOWN_ARGS", False):
        args, extra = parser.parse_known_args(argv[1:])
        args.extra = extra
    else:
        args = parser.parse_args(argv[1:])
    return int(module.main(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
