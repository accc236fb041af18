"""``buildhat-conformance run``: its command line (the run itself, a child pytest in a new run folder,
is conformance/runner.py)."""
from __future__ import annotations

import argparse

from ..harness.lab.selection import add_lab_arguments
from ..plumbing.cli_options import DEFAULT_SPEED, RELEASE_HELP, SPEED_HELP, add_target_option
from .case_order import RANDOM
from .lab_run import hold_for_run
from .run_passthrough import PYTEST_HELP, UNKNOWN_ARGS_HINT, refused_arguments
from .runner import run

__all__ = ["add_arguments", "main", "PASS_UNKNOWN_ARGS", "UNKNOWN_ARGS_HINT", "refused_arguments"]


# The dispatcher (buildhat_conformance/cli.py) hands on what follows `--`, and what refused_arguments
# lets through, to pytest as `args.extra`.
PASS_UNKNOWN_ARGS = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = PYTEST_HELP
    add_target_option(parser, multiple=True,
                      extra_help="several: one xdist worker each, one merged report (docs/LAB.md; "
                                 "or --inventory FILE)")
    parser.add_argument("--speed", type=float, default=DEFAULT_SPEED, metavar="N",
                        help=f"{SPEED_HELP}, for emulator URLs that give no ?speed= (default "
                             f"{DEFAULT_SPEED:g})")
    parser.add_argument("--firmware", default=None, metavar="RELEASE",
                        help=f"judge as this release ({RELEASE_HELP}) instead of the one the target "
                             "reports; to run an emulator of a release, name it in the URL (emulator:R2)")
    parser.add_argument("--inventory", default=None, metavar="FILE",
                        help="run against every HAT listed in FILE (one 'NAME URL' or 'URL' a line; "
                             "docs/LAB.md)")
    parser.add_argument("--junit", default=None, metavar="FILE",
                        help="JUnit XML output (default: a new run folder reports/runs/<time>-<target>/, "
                             "with reports/latest, reports/junit.xml and reports/index.html updated when "
                             "cases ran)")
    parser.add_argument("--transcripts", default=None, metavar="DIR",
                        help="folder for the per-case transcripts (default: transcripts/ beside the JUnit "
                             "file)")
    parser.add_argument("-k", dest="keyword", default=None, metavar="EXPR",
                        help="only the cases matching this pytest -k expression "
                             "(e.g. 'select and not combi')")
    parser.add_argument("--random-order", nargs="?", const=RANDOM, default=None, metavar="SEED",
                        help="run the cases in an order shuffled with SEED (pytest-randomly), or with a new "
                             "seed that the run prints; default: the suite's own order")
    parser.add_argument("--operator", action="store_true", help="ask a person for plug/unplug actions")
    parser.add_argument("--max-target-faults", type=int, default=None, metavar="N",
                        help="after N target faults in a row reset the HAT once if the target can (the "
                             "emulator, or ?reset=gpio on a Raspberry Pi) and go on if it comes back; else "
                             "stop talking to the target and report the remaining cases as not run "
                             "(default 5; 0: never stop)")
    parser.add_argument("--image", default=None, metavar="FILE",
                        help="load this firmware image through the HAT's bootloader before the suite, "
                             "and again if the run resets a dead HAT (with --signature; as "
                             "'buildhat-conformance load')")
    parser.add_argument("--signature", default=None, metavar="FILE", help="the image's 64-byte signature")
    parser.add_argument("--baseline", default=None, metavar="URL",
                        help="also run the suite on this target (e.g. sil:OLD-TREE) and list every case "
                             "whose HAT output differs from it, timing-only differences told apart "
                             "(docs/COMPARING-BUILDS.md)")
    parser.add_argument("--expect-changes", default=None, metavar="FILE",
                        help="with --baseline: the cases meant to change (one case id or pattern a line, "
                             "# comments); a difference outside them fails the run")
    add_lab_arguments(parser)


def main(args: argparse.Namespace) -> int:
    # labgrid places (--places, labgrid: targets) are held from here to the end (conformance/lab_run.py)
    give_back = hold_for_run(args)
    try:
        return run(args)
    finally:
        if give_back is not None:
            give_back()
