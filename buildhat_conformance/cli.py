"""buildhat-conformance: one command, one sub-command per job.

The entry point and its dispatcher, at the package root: the only module that names every
folder (as strings: only the chosen sub-command is imported). Each sub-command lives in the
folder that owns it and provides two functions, ``add_arguments(parser)`` and
``main(args) -> int``.
A user's mistake (a bad option, file or target) is one line on stderr, starting with
``buildhat-conformance COMMAND:``, and the exit status of plumbing/cli_options.py, the same in
every sub-command; a traceback means a bug of ours. Each ``--help`` ends with the exit statuses
that command really returns (plumbing/cli_exits.py).

A sub-command that hands arguments on to another program (``run`` to pytest, ``record --proxy``
to the host program) sets ``PASS_UNKNOWN_ARGS``: what follows ``--`` is handed on as it is, and
its ``refused_arguments(args, unknown)`` says which of the other unknown arguments are mistakes
(answered like any bad option, with its ``UNKNOWN_ARGS_HINT``).
"""
# The folders install under this package's name (setup.py maps harness/ to
# buildhat_conformance.harness ...); pyright reads the checkout, where they sit beside this folder.
# pyright: reportMissingImports=false
from __future__ import annotations

import argparse
import importlib
import os
import sys
from types import ModuleType
from typing import List, Optional, Sequence, Tuple

from .harness.targets.base import TargetError
from .plumbing.cli_exits import exit_status_help
from .plumbing.cli_options import EXIT_TARGET, EXIT_USAGE, OneLineParser, UsageError
from .plumbing.package_version import __version__

SUBCOMMANDS = {
    "run": ("buildhat_conformance.conformance.cli_run", "run the conformance suite against a target"),
    "script": ("buildhat_conformance.transcripts.cli_script",
               "run one scenario script and write its transcript"),
    "targets": ("buildhat_conformance.cli_targets", "list the targets this machine can see"),
    "fuzz": ("buildhat_conformance.fuzz.cli", "grammar-based and stateful fuzzing of a target"),
    "record": ("buildhat_conformance.transcripts.cli_record", "record a scenario's transcript on a target"),
    "replay": ("buildhat_conformance.transcripts.cli_replay",
               "replay a transcript against a target and diff"),
    "mock": ("buildhat_conformance.transcripts.cli_mock", "serve a transcript as a fake HAT"),
    "report": ("buildhat_conformance.conformance.report.cli", "build the HTML report from JUnit files"),
    "load": ("buildhat_conformance.cli_load", "load firmware through the HAT's bootloader"),
    "bench": ("buildhat_conformance.bench.cli", "benchmarks: timing, throughput, fidelity"),
    "sil": ("buildhat_conformance.cli_sil", "the real firmware on this host: build a tree (sil build)"),
    "rp2040": ("buildhat_conformance.rp2040.cli",
               "a release's firmware.bin on an emulated RP2040: install rp2040js (rp2040 setup)"),
}

PROG = "buildhat-conformance"
# The commands that choose a profile: each takes --profiles FILE, builds the package does not know
# (docs/PROFILES.md), for itself and every process it starts.
PROFILE_COMMANDS = ("run", "script", "fuzz", "record", "replay", "targets")
_EPILOG = ("Every COMMAND takes --help, which ends with the exit statuses it returns. -t URL: the target; "
           "by default emulator, which means emulator:latest?speed=10 (the reference emulator, latest "
           "release, ten times real time; add ?speed=1 for real time), but in fuzz inprocess (the emulator "
           "in its own process, in virtual time) and in load emulator:?bootloader=1; "
           f"'{PROG} targets' lists the others. {exit_status_help(PROG)}")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog=PROG, description=(__doc__ or "").splitlines()[0], epilog=_EPILOG)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (_module, help_text) in SUBCOMMANDS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def _say(name: str, message: str) -> None:
    from .harness.preflight import one_line

    print(f"{PROG} {name}: {one_line(message)}", file=sys.stderr)


def _split_at_dashes(argv: List[str]) -> Tuple[List[str], List[str]]:
    """(what comes before the first ``--``, what comes after it)."""
    if "--" not in argv:
        return argv, []
    at = argv.index("--")
    return argv[:at], argv[at + 1:]


def parse(module: ModuleType, parser: argparse.ArgumentParser, argv: List[str]) -> argparse.Namespace:
    """The sub-command's arguments; a bad one exits 2 in one line (OneLineParser)."""
    if not getattr(module, "PASS_UNKNOWN_ARGS", False):
        return parser.parse_args(argv)
    before, after = _split_at_dashes(argv)
    args, unknown = parser.parse_known_args(before)
    refused = module.refused_arguments(args, unknown)
    if refused:
        hint = getattr(module, "UNKNOWN_ARGS_HINT", "")
        parser.error(f"unrecognized arguments: {' '.join(refused)}" + (f"; {hint}" if hint else ""))
    args.extra = unknown + after
    return args


def command_parser(name: str, module: ModuleType) -> argparse.ArgumentParser:
    """The parser of sub-command ``name`` (``module`` its imported module), as ``main`` uses it."""
    parser = OneLineParser(prog=f"{PROG} {name}", description=SUBCOMMANDS[name][1])
    module.add_arguments(parser)
    if name in PROFILE_COMMANDS:
        parser.add_argument("--profiles", default=None, metavar="FILE",
                            help="builds the package does not know, each a release it starts from and "
                                 "what it changes (docs/PROFILES.md): a target that reports one "
                                 "is judged by it, and emulator:NAME runs it (default: "
                                 "$BUILDHAT_CONFORMANCE_PROFILES)")
    # the command's own notes (if any), then its exit statuses
    parser.epilog = " ".join(filter(None, [parser.epilog, exit_status_help(name)]))
    return parser


def _use_profiles(path: Optional[str]) -> List[str]:
    """Take the user's profiles file (``--profiles``, else the environment's): its mistakes, one
    line each, or none."""
    from .protocol.profile_file import ProfileFileError
    from .protocol.profiles import PROFILES_ENV, use_profiles_file

    path = path or os.environ.get(PROFILES_ENV)
    if not path:
        return []
    try:
        use_profiles_file(path)
    except ProfileFileError as exc:
        return exc.lines
    return []


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:
        build_parser().error(f"give a COMMAND: {', '.join(SUBCOMMANDS)}")
    if argv[0] in ("-h", "--help"):
        build_parser().print_help()
        return 0
    if argv[0] not in SUBCOMMANDS:
        build_parser().parse_args(argv)    # --version, or one line naming the unknown command
        return EXIT_USAGE
    name = argv[0]
    module_name = SUBCOMMANDS[name][0]
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and module_name.startswith(exc.name):
            _say(name, f"not available in this build ({exc.name})")
            return EXIT_USAGE
        raise
    args = parse(module, command_parser(name, module), argv[1:])
    mistakes = _use_profiles(getattr(args, "profiles", None))
    if mistakes:
        for line in mistakes:
            _say(name, line)
        return EXIT_USAGE
    try:
        return int(module.main(args) or 0)
    except UsageError as exc:
        _say(name, str(exc))
        return EXIT_USAGE
    except TargetError as exc:
        _say(name, str(exc))
        return EXIT_TARGET
    except BrokenPipeError:
        # The reader went away (`... | head`): nothing is wrong, and nothing more can be said.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:
        if not exc.filename:
            raise                   # not a file the user named: a bug of ours, with its traceback
        _say(name, f"{exc.filename}: {exc.strerror or exc}")
        return EXIT_USAGE
    except KeyboardInterrupt:
        _say(name, "interrupted")
        return 130


if __name__ == "__main__":
    sys.exit(main())
