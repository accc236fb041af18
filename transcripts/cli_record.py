"""``buildhat-conformance record``: its command line (the recording itself is transcripts/record.py)."""
from __future__ import annotations

import argparse
import sys
from typing import List

from ..harness.targets.base import NeedsCapability
from ..plumbing.cli_options import BOOT_TIMEOUT_S, EXIT_TARGET, UsageError, add_target_option, check_writable
from .record import ready_lines, record_proxy, record_script
from .script import ScriptError, load_script

__all__ = ["add_arguments", "main", "PASS_UNKNOWN_ARGS", "UNKNOWN_ARGS_HINT", "refused_arguments"]


# `record --proxy ... -- COMMAND ARGS`: the command's own options must reach it untouched (the
# dispatcher hands on what follows `--`, buildhat_conformance/cli.py).
PASS_UNKNOWN_ARGS = True
UNKNOWN_ARGS_HINT = "a host program's command goes after -- (with --proxy)"


def refused_arguments(args: argparse.Namespace, unknown: List[str]) -> List[str]:
    """Before ``--`` only the words of a --proxy command (an older spelling) are not mistakes."""
    if not args.proxy:
        return unknown
    return [a for a in unknown if a.startswith("-")]


# -- command line --------------------------------------------------------------------------------
def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("script", nargs="?", metavar="SCRIPT", help="scenario script (.script) to run")
    add_target_option(parser)
    parser.add_argument("-o", "--output", required=True, metavar="FILE", help="transcript to write (.jsonl)")
    parser.add_argument("--boot-timeout", type=float, default=BOOT_TIMEOUT_S, metavar="S",
                        help="a booting target has up to S seconds (HAT time) to bring up the start-up "
                             "layout before the script starts, or with --proxy before the host is let in "
                             f"(default {BOOT_TIMEOUT_S:g}; with --proxy 0 means never wait)")
    parser.add_argument("--proxy", action="store_true",
                        help="record a host program's session through a pty instead of a script; "
                             "the command follows '--' ({device} = the pty path)")
    parser.add_argument("--link", metavar="PATH", help="with --proxy: also make this symlink to the pty")


def main(args: argparse.Namespace) -> int:
    from ..harness.preflight import checked_target

    extra = list(getattr(args, "extra", []))
    check_writable(args.output, "-o")
    if args.proxy:
        if args.script:
            extra = [args.script] + extra
        target = checked_target(args.target)
        from ..protocol.devices import DEFAULT_LAYOUT

        layout = dict(DEFAULT_LAYOUT)
        layout.update(getattr(target, "devices", None) or {})   # an emulator URL's device= options
        status = record_proxy(target, args.output, extra, args.link, ready=ready_lines(layout),
                              boot_timeout=args.boot_timeout)
        exited = f" (the host program exited with {status})" if status else ""
        print(f"record: wrote {args.output}{exited}")
        return status
    if extra:
        raise UsageError(f"unexpected arguments {' '.join(extra)} (a command goes with --proxy)")
    if not args.script:
        raise UsageError("give a SCRIPT, or --proxy to record a host program")
    try:
        script = load_script(args.script)
    except FileNotFoundError:
        raise UsageError(f"{args.script}: no such script") from None
    except (OSError, ScriptError) as exc:
        raise UsageError(str(exc)) from None
    target = checked_target(args.target, layout=script.devices if script.explicit_devices else None)
    try:
        _transcript, remarks = record_script(script, target, args.output, args.boot_timeout)
    except NeedsCapability as exc:
        print(f"buildhat-conformance record: cannot run {args.script} on {args.target}: it {exc}. "
              "Nothing was "
              "sent; use a target with a control channel (emulator, inprocess) or a rig.", file=sys.stderr)
        return EXIT_TARGET
    except OSError as exc:
        raise UsageError(f"{args.output}: {exc.strerror or exc}") from None
    for r in remarks:
        print(f"record: note: {r}")
    print(f"record: wrote {args.output}")
    return 0
