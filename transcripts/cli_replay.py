"""``buildhat-conformance replay``: its command line (planning, replaying and comparing are
transcripts/replay.py)."""
from __future__ import annotations

import argparse
import sys

from ..plumbing.cli_options import BOOT_TIMEOUT_S, UsageError, add_target_option, check_writable
from .compare import RuleSet
from .replay import compare_transcripts, missing_capabilities, plan_replay, replay
from .script import load_script

__all__ = ["add_arguments", "main"]


# -- command line ----------------------------------------------------------------------------
def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("transcript", metavar="FILE", help="the recorded transcript (.jsonl)")
    add_target_option(parser)
    parser.add_argument("--rule", action="append", default=[], metavar="CLASS=RULE",
                        help="comparison rule per event class: exact | pattern:REGEX | tolerance:N[%%] | "
                             "ignore (repeatable; CLASS 'data' = all data lines, '*' = default)")
    parser.add_argument("--timing-tolerance", type=float, metavar="MS",
                        help="also compare line times, within ±MS HAT milliseconds")
    parser.add_argument("--include-startup", action="store_true",
                        help="compare the start-up output before the first host line too")
    parser.add_argument("--script", metavar="FILE", help="the scenario script that produced the recording "
                        "(default: meta.script)")
    parser.add_argument("--without-world", action="store_true",
                        help="replay the host bytes even though the target cannot perform the world actions")
    parser.add_argument("-o", "--output", metavar="FILE", help="keep what came back as a transcript")
    parser.add_argument("--boot-timeout", type=float, default=BOOT_TIMEOUT_S, metavar="S",
                        help="a booting target has up to S seconds (HAT time) to bring up the recording's "
                             f"start-up layout (default {BOOT_TIMEOUT_S:g})")


def main(args: argparse.Namespace) -> int:
    from ..harness.preflight import checked_target
    from .script import ScriptError
    from .transcript_check import load_transcript

    recorded = load_transcript(args.transcript)
    if args.output:
        check_writable(args.output, "-o")   # before the run: its result is not lost at the end
    try:
        rules = RuleSet.from_options(args.rule, args.timing_tolerance)
    except ValueError as exc:
        raise UsageError(f"--rule: {exc}") from None
    try:
        script = load_script(args.script) if args.script else None
    except FileNotFoundError:
        raise UsageError(f"{args.script}: no such script") from None
    except ScriptError as exc:
        raise UsageError(str(exc)) from None
    try:
        plan = plan_replay(recorded, args.transcript, script)
    except (OSError, ValueError) as exc:
        raise UsageError(f"{args.transcript}: {exc}") from None
    target = checked_target(args.target, layout=plan.layout)   # the recording's start-up layout
    missing = missing_capabilities(plan, target)
    if missing and not args.without_world:
        print(f"buildhat-conformance replay: cannot replay {args.transcript} faithfully on {args.target}: "
              f"the recording's world actions need {', '.join('@' + m for m in missing)} "
              f"(from its {plan.world_source}), "
              "which this target cannot perform. Use a target with a control channel (emulator, "
              "inprocess), or --without-world to send the host bytes alone.", file=sys.stderr)
        return 3
    if missing:
        plan.steps = [s for s in plan.steps if s.kind != "world"]
        plan.remarks.append(f"world actions left out (--without-world): {', '.join(missing)}")
    actual, slack, remarks = replay(recorded, target, plan, args.output, args.boot_timeout)
    result = compare_transcripts(recorded, actual, rules, include_startup=args.include_startup,
                                 trim_after=plan.end_t + slack if slack else None)
    hosts = [e for e in recorded.events if e.get("dir") == "host"]
    for r in remarks:
        print(f"replay: note: {r}")
    if args.output:
        print(f"replay: what came back is in {args.output}")
    print(f"replay: {args.transcript} on {args.target} (rules: {rules.describe()})")
    print(result.render(hosts))
    return 0 if result.ok else 1
