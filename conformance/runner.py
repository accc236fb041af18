"""``buildhat-conformance run``: the conformance suite against one target.

Runs pytest on the installed ``conformance`` package in a child process (so a target that
hangs or dies cannot take the caller with it), writes the JUnit file, builds the HTML
report when ``buildhat_conformance.harness.report`` is available, and exits non-zero on
any failure. Options it does not know are passed to pytest unchanged.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
from typing import List

PASS_UNKNOWN_ARGS = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--target", action="append", default=None,
                        help="target URL (default: emulator); several: one xdist worker each, one merged "
                             "report (docs/LAB.md; or --inventory FILE)")
    parser.add_argument("--firmware", default=None, help="judge against this release instead of detecting it")
    parser.add_argument("--junit", default=None,
                        help="JUnit XML output (default: a new run folder reports/runs/<time>-<target>/, "
                             "with reports/latest, reports/junit.xml and reports/index.html updated when "
                             "cases ran)")
    parser.add_argument("--transcripts", default=None,
                        help="folder for per-case transcripts (default: beside the JUnit file)")
    parser.add_argument("-k", dest="keyword", default=None, help="only tests matching this pytest expression")
    parser.add_argument("--operator", action="store_true", help="ask a person for plug/unplug actions")
    parser.add_argument("--image", default=None, metavar="FILE",
                        help="load this firmware image through the HAT's bootloader before the suite "
                             "(with --signature; as `buildhat-conformance load`)")
    parser.add_argument("--signature", default=None, metavar="FILE", help="the image's 64-byte signature")


def suite_dir() -> str:
    return os.path.dirname(os.path.abspath(__file__))


def pytest_argv(args: argparse.Namespace) -> List[str]:
    junit = os.path.abspath(args.junit)
    transcripts = args.transcripts or os.path.join(os.path.dirname(junit), "transcripts")
    # H10: --target may be given several times (conformance/multitarget.py runs one worker each).
    targets = args.target if isinstance(args.target, list) else [args.target or "emulator"]
    argv = [sys.executable, "-m", "pytest", suite_dir(), "-p", "no:cacheprovider", "--rootdir", suite_dir(),
            *[a for t in targets for a in ("--target", t)], "--conformance-junit", junit,
            "--transcripts", transcripts, "--import-mode=importlib", "-q",
            # The suite uses no Hypothesis; its pytest plugin imports the library in the terminal
            # summary, two seconds of every run (H10 profile).
            "-p", "no:hypothesispytest"]
    argv += ["--conformance-html", os.path.join(os.path.dirname(junit), "index.html")]
    if args.firmware:
        argv += ["--firmware", args.firmware]
    if args.keyword:
        argv += ["-k", args.keyword]
    if args.operator:
        argv += ["--operator", "-s"]
    return argv + list(getattr(args, "extra", []) or [])


def build_html_report(junit: str) -> None:
    """Write ``index.html`` beside the JUnit file; the suite's closing line has named it."""
    from ..harness.report import build_report

    try:
        build_report([junit], os.path.join(os.path.dirname(junit), "index.html"))
    except Exception as exc:  # noqa: BLE001 - the report is extra; the verdict is the exit status
        print(f"buildhat-conformance: HTML report not built: {exc}", file=sys.stderr)


def load_image_first(args: argparse.Namespace) -> int:
    """``--image/--signature``: load the release under test into every target before any case
    runs (harness/firmware/). Returns 0, or the exit status of a failed load (one line said why)."""
    from ..harness.firmware.cli import load_from_args
    from ..harness.firmware.errors import EXIT_USAGE, LoadError
    from ..harness.targets import TargetError, make_target

    prog = "buildhat-conformance run"
    if not (args.image and args.signature):
        print(f"{prog}: --image and --signature go together (the bootloader needs both)", file=sys.stderr)
        return EXIT_USAGE
    targets = args.target if isinstance(args.target, list) else [args.target or "emulator"]
    for url in targets:
        try:
            disposable = make_target(url).disposable
        except TargetError as exc:
            print(f"{prog}: {' '.join(str(exc).split())}", file=sys.stderr)
            return EXIT_USAGE
        if disposable:
            print(f"{prog}: --image needs a HAT that outlives one connection, and {url} starts a new one for "
                  "each; start one with `buildhat-emulator --pty --bootloader --link /tmp/hat` and use "
                  "--target /tmp/hat", file=sys.stderr)
            return EXIT_USAGE
        transcript = os.path.join(os.path.dirname(os.path.abspath(args.junit)), "load.jsonl")
        try:
            result = load_from_args(url, args.image, args.signature, transcript=transcript)
        except LoadError as exc:
            print(f"{prog}: loading {args.image} into {url}: {exc}", file=sys.stderr)
            return exc.exit_status
        print(f"loaded: firmware version {result.firmware_version} into {url}", flush=True)
    return 0


def main(args: argparse.Namespace) -> int:
    from ..harness.report import runs

    folder = runs.start_for(args)        # None when --junit names the file explicitly
    if args.image or args.signature:
        status = load_image_first(args)
        if status:
            if folder is not None:
                print(runs.finish(folder))   # no case ran: reports/ stays as it was
            return status
    # The suite's own folder is the rootdir; pytest.ini options of the caller's project are not ours.
    code = subprocess.call(pytest_argv(args))
    if folder is None or runs.cases_ran(folder.junit):
        build_html_report(os.path.abspath(args.junit))
    if folder is not None:
        print(runs.finish(folder))
    return 0 if code == 0 else (code or 1)
