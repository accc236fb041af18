"""``buildhat-conformance report``: rebuild the HTML report from JUnit files (several targets or
profiles side by side), or list and prune the run folders under ``reports/runs/``."""
from __future__ import annotations

import argparse
import os
import sys
import xml.etree.ElementTree as ET

from . import build_report
from .junit import check_junit
from .runs import DEFAULT_ROOT, list_runs, prune

PROG = "buildhat-conformance report"      # every error line starts so, as in every command


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("junit", nargs="*", metavar="JUNIT", help="JUnit XML files written by the suite")
    parser.add_argument("-o", "--output", default="reports/index.html", metavar="FILE",
                        help="the HTML page to write (default %(default)s)")
    parser.add_argument("--check", action="store_true",
                        help="also fail (exit 1) when a JUnit file would trip common CI readers")
    parser.add_argument("--list", action="store_true", help="list the run folders under REPORTS/runs/")
    parser.add_argument("--prune", type=int, metavar="N", default=None,
                        help="delete all run folders but the newest N (never the one REPORTS/latest names)")
    parser.add_argument("--reports", default=DEFAULT_ROOT, metavar="REPORTS",
                        help="the reports folder of --list and --prune (default %(default)s)")


def _runs_command(args: argparse.Namespace) -> int:
    if args.prune is not None:
        if args.prune < 0:
            print(f"{PROG}: --prune needs the number of runs to keep (0 or more)", file=sys.stderr)
            return 2
        gone = prune(args.reports, args.prune)
        print(f"report: deleted {len(gone)} run folder(s) from {os.path.join(args.reports, 'runs')}")
    if args.list:
        runs = list_runs(args.reports)
        if not runs:
            print(f"report: no run folders under {os.path.join(args.reports, 'runs')}")
        for r in runs:
            print(r.line())
    return 0


def main(args: argparse.Namespace) -> int:
    if args.list or args.prune is not None:
        return _runs_command(args)
    if not args.junit:
        print(f"{PROG}: give JUnit files to report on, or --list / --prune N", file=sys.stderr)
        return 2
    missing = [p for p in args.junit if not os.path.isfile(p)]
    if missing:
        print(f"{PROG}: no such JUnit file: {', '.join(missing)}", file=sys.stderr)
        return 2
    bad = 0
    for path in args.junit:
        for problem in check_junit(path):
            bad += 1
            print(f"{PROG}: {path}: {problem}", file=sys.stderr)
    try:
        out = build_report(args.junit, args.output)
    except ET.ParseError:
        return 2          # check_junit has said which file and where it stops being XML
    except (OSError, ValueError) as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    print(f"report: wrote {out}")
    return 1 if (bad and args.check) else 0
