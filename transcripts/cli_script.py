"""``buildhat-conformance script FILE --target URL [-o TRANSCRIPT]``: run one scenario script
against a target and write its transcript.

Exit status (plumbing/cli_options.py): 0 the script ran to the end; 2 the script or the command
line is wrong; 3 the target is unreachable, went away mid-run, or cannot do what the script
needs (a world action or the start-up layout: then nothing was sent).
"""
from __future__ import annotations

import argparse
import os
import re
import sys

from ..harness.errors import NeedsCapability, TargetError
from ..harness.preflight import checked_target, one_line
from ..plumbing.cli_options import EXIT_OK, EXIT_TARGET, EXIT_USAGE, add_target_option, check_writable
from .script import ScriptError, load_script
from .script_runner import run_script


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("script", metavar="FILE", help="the scenario script (.script)")
    add_target_option(parser)
    parser.add_argument("-o", "--output", metavar="TRANSCRIPT",
                        help="transcript file (default: reports/<script>.<target>.jsonl if ./reports "
                             "exists, else beside the script)")
    parser.add_argument("--layout-on-rig", action="store_true",
                        help="the HAT is wired as the script's @device lines say; check it with 'list'")
    parser.add_argument("--open-timeout", type=float, default=2.0, metavar="S",
                        help="seconds to wait for each 'version' answer at open (default 2)")
    parser.add_argument("--quiet", "-q", action="store_true", help="print only errors")


def default_transcript_path(script_path: str, target_url: str) -> str:
    stem = os.path.splitext(os.path.basename(script_path))[0]
    slug = re.sub(r"[^A-Za-z0-9.]+", "_", target_url).strip("_")[:40] or "target"
    name = f"{stem}.{slug}.jsonl"
    if os.path.isdir("reports"):
        return os.path.join("reports", name)
    return os.path.join(os.path.dirname(os.path.abspath(script_path)), name)


def main(args: argparse.Namespace) -> int:
    def err(text: str) -> None:
        print(f"buildhat-conformance script: {text}", file=sys.stderr)

    try:
        script = load_script(args.script)
    except FileNotFoundError:
        err(f"no such script: {args.script}")
        return EXIT_USAGE
    except ScriptError as exc:
        err(str(exc))
        return EXIT_USAGE
    output = args.output or default_transcript_path(args.script, args.target)
    check_writable(output, "-o")
    # an emulator starts with the script's layout
    target = checked_target(args.target, layout=script.devices if script.explicit_devices else None)
    try:
        result = run_script(script, target, transcript=output, open_timeout=args.open_timeout,
                            layout_on_rig=args.layout_on_rig)
    except NeedsCapability as exc:
        err(f"skipped {args.script}: {exc}")
        return EXIT_TARGET
    except TargetError as exc:
        err(one_line(exc))
        return EXIT_TARGET
    if not result.ok:
        err(one_line(f"{args.script} on {args.target}: {result.reason}; transcript (every byte received "
                     f"until then): {output}"))
        return EXIT_TARGET
    if not args.quiet:
        lines = sum(1 for e in result.events if e.kind not in ("prompt", "bootloader_prompt"))
        print(f"{script.name or args.script}: ran on {args.target} (firmware {result.firmware}); "
              f"{len(result.received)} bytes received, {lines} lines during the script")
        for note in result.notes:
            print(f"note: {note}")
        print(f"transcript: {output}")
    return EXIT_OK
