"""``buildhat-conformance report JUNIT... [-o HTML]``: rebuild the HTML report from JUnit files
(several targets or profiles side by side)."""
from __future__ import annotations

import argparse
import os
import sys
import xml.etree.ElementTree as ET

from . import build_report
from .junit import check_junit


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("junit", nargs="+", metavar="JUNIT", help="JUnit XML files written by the suite")
    parser.add_argument("-o", "--output", default="reports/index.html",
                        help="HTML file (default %(default)s)")
    parser.add_argument("--check", action="store_true",
                        help="also fail (exit 1) when a JUnit file would trip common CI readers")


def main(args: argparse.Namespace) -> int:
    missing = [p for p in args.junit if not os.path.isfile(p)]
    if missing:
        print(f"report: no such JUnit file: {', '.join(missing)}", file=sys.stderr)
        return 2
    bad = 0
    for path in args.junit:
        for problem in check_junit(path):
            bad += 1
            print(f"report: {path}: {problem}", file=sys.stderr)
    try:
        out = build_report(args.junit, args.output)
    except (ET.ParseError, ValueError) as exc:
        if not bad:   # check_junit has said what is wrong with the file, in one line
            print(f"report: cannot read {', '.join(args.junit)}: {exc}", file=sys.stderr)
        return 2
    print(f"report: wrote {out}")
    return 1 if (bad and args.check) else 0
