"""``buildhat-conformance fuzz``: grammar-based, stateful fuzzing of a target (optionally against another).

    buildhat-conformance fuzz -t inprocess:R7 --budget 30s --seed 1
    buildhat-conformance fuzz -t /dev/serial0 --against emulator --budget 500x
    buildhat-conformance fuzz --reproduce reports/fuzz/fate.script -t emulator:R7
    buildhat-conformance fuzz -t sil:~/buildhat/firmware-pico --against inprocess --jobs 2   #
    fuzz/running/workers.py

Findings (one per oracle, confirmed by replays and reduced) are written to ``-o/--output`` (default
``reports/fuzz``; ``--out`` is its old spelling): ``<oracle>.script`` (replay with ``--reproduce``
or ``buildhat-conformance script``), ``<oracle>.<target>.jsonl`` transcripts and ``junit.xml``.
Exit status: 0 no findings, 1 findings (with ``--reproduce``: 1 reproduced, 0 not), 2 usage
errors, 3 a campaign that could not do its job
(a target that cannot be reached, answers as another release than ``--firmware``, or took no input),
130 interrupted: the first Ctrl-C (or SIGTERM) stops the campaign and still writes what it found
(fuzz/running/stop_signals.py), a second kills it at once.
"""
from __future__ import annotations

import argparse
import os
import sys

from ..harness.targets.base import TargetError
from ..plumbing.cli_options import RELEASE_HELP, add_hidden_alias
from ..transcripts.script import ScriptError
from .findings.reproduce import reproduce
from .inputs.generate import FAMILIES
from .oracles.registry import oracles
from .running.from_arguments import DEFAULT_OUT, DEFAULT_TARGET, run
from .running.target_kinds import is_fresh
from .running.worker_count import AUTO_JOBS_MAX, JOBS_ENV, jobs_value, resolve_jobs

__all__ = ["add_arguments", "main", "check_jobs"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-t", "--target", default=None, metavar="URL",
                        help=f"target URL (default: {DEFAULT_TARGET}, the emulator in this process, latest "
                             "release, in virtual time; with --reproduce, the finding's own); "
                             "'buildhat-conformance targets' lists the others")
    parser.add_argument("--against", default=None, metavar="URL",
                        help="differential mode: send the same input to this second target and compare")
    parser.add_argument("--budget", default="30s", metavar="TIME|Nx",
                        help="how long to fuzz: 60s / 2m / 1h (wall clock) or 500x (runs); default 30s")
    parser.add_argument("--seed", type=int, default=None, metavar="N",
                        help="campaign seed (default: chosen at random, printed and stored with the results)")
    parser.add_argument("--confirm", type=int, default=3, metavar="N",
                        help="replays of a failing run before it is reported (and with --reproduce, at "
                             "least 1); 0: a failing run is reported as found, never replayed (neither "
                             "confirmed nor reduced); default 3")
    parser.add_argument("--reproduce", default=None, metavar="FINDING",
                        help="replay a finding's script against the target: prints reproduced (exit 1) "
                             "or not reproduced (exit 0)")
    parser.add_argument("--database", default=None, metavar="PATH",
                        help="where failing runs are kept for the next campaign (default: DIR/.examples)")
    parser.add_argument("--no-database", action="store_true", help="do not read or save failing runs")
    parser.add_argument("-o", "--output", dest="out", default=DEFAULT_OUT, metavar="DIR",
                        help=f"folder the findings go to (default {DEFAULT_OUT})")
    add_hidden_alias(parser, "--out", dest="out")
    parser.add_argument("--junit", default=None, metavar="FILE", help="JUnit file (default: DIR/junit.xml)")
    parser.add_argument("--firmware", dest="profile", default=None, metavar="RELEASE",
                        help=f"judge as this release ({RELEASE_HELP}) instead of the one the target "
                             "reports; to fuzz an emulator of a release, name it in the URL (inprocess:R2)")
    add_hidden_alias(parser, "--profile", dest="profile")
    parser.add_argument("--families", default=",".join(FAMILIES), metavar="NAME,...",
                        help=f"input families, comma-separated (default: {','.join(FAMILIES)})")
    parser.add_argument("--steps", type=int, default=100, metavar="N", help="steps per run (default 100)")
    parser.add_argument("--batch", type=int, default=32, metavar="N",
                        help="at most this many inputs sent back to back in one step, with one fence "
                             "(default 32)")
    parser.add_argument("--waits", default="10,60,300", metavar="MS,...",
                        help="HAT milliseconds the wait rule may let pass, comma-separated; empty: no "
                             "wait rule (default 10,60,300)")
    parser.add_argument("--fence-timeout", type=float, default=None, metavar="S",
                        help="HAT seconds a fence may take beyond the time its output needs on the wire "
                             "(default: 0.3 in-process, where nothing is slower than the wire; else 2)")
    parser.add_argument("--shrink-time", type=float, default=30.0, metavar="S",
                        help="seconds a finding may spend being reduced by replaying smaller scripts "
                             "(default 30)")
    parser.add_argument("--check-time", default=None, metavar="TIME",
                        help="wall-clock time the campaign may spend checking findings in all (confirming "
                             "and reducing them; not counted in --budget): 90s, 2m; a finding it cuts "
                             "short is reported as far as it was checked, and the summary says so "
                             "(default: a quarter of a time budget; with a run budget, no bound beyond "
                             "--confirm and --shrink-time)")
    parser.add_argument("--jobs", type=jobs_value, default="auto", metavar="N",
                        help="run N campaign workers at once, each with targets of its own, into one "
                             "summary (targets started anew at each open: inprocess, emulator, cmd:, "
                             "sil:; for several real HATs use --places); default auto: one per usable "
                             f"CPU (at most {AUTO_JOBS_MAX}, or ${JOBS_ENV}) when every target is one this "
                             "program starts (inprocess, emulator, sil:), else 1")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    from ..harness.lab.selection import add_lab_arguments

    add_lab_arguments(parser, "one campaign per place, into -o/<place>/")
    # Read from the registry, so an added oracle is listed too (fuzz/oracles/registry.py).
    parser.add_argument_group("oracles (each a finding of its own and a JUnit case)",
                              "; ".join(f"{o.name}: {o.help}" for o in oracles()) + ".")


def main(args: argparse.Namespace) -> int:
    from .running.places import hold_for_campaign, run_places

    check_jobs(args)
    # labgrid places are held for the whole campaign, or all campaigns (fuzz/running/places.py)
    give_back = hold_for_campaign(args)
    try:
        if args.places:
            from ..plumbing.cli_options import check_writable

            check_writable(args.out, "-o", folder=True)
            return run_places(args)
        return _main(args)
    finally:
        if give_back is not None:
            give_back()


def check_jobs(args: argparse.Namespace) -> None:
    """``--jobs N`` needs targets that start a new HAT at every open (one per worker); ``auto``
    becomes a number here (fuzz/running/worker_count.py)."""
    from ..plumbing.cli_options import UsageError

    jobs = resolve_jobs(args, DEFAULT_TARGET)
    if jobs < 1:
        raise UsageError(f"--jobs takes a positive number of workers, got {jobs}")
    if jobs == 1:
        return
    if args.reproduce or getattr(args, "places", None):
        raise UsageError("--jobs runs campaign workers: it does not go with --reproduce or --places")
    for url in (args.target or DEFAULT_TARGET, args.against):
        if url and not is_fresh(url):
            raise UsageError(f"--jobs {jobs}: {url} is one HAT, which one worker at a time can use "
                             "(--jobs needs inprocess, emulator, cmd: or sil: targets; for several "
                             "HATs, --places)")


def _main(args: argparse.Namespace) -> int:
    from ..harness.preflight import check_release, checked_target
    from ..plumbing.cli_options import check_writable

    # The checks every sub-command makes before it starts (2 a bad URL, release or output
    # folder; 3 unreachable), so a campaign is never lost at its end.
    for url in (args.target, args.against):
        if url:
            checked_target(url)
    if args.profile:
        check_release(args.profile, "--firmware")
    if not args.reproduce:
        check_writable(args.out, "-o", folder=True)
        if args.junit:
            check_writable(args.junit, "--junit")
    try:
        if args.reproduce:
            return reproduce(args)
        result, _files = run(args)
    except (ValueError, KeyError, ScriptError) as exc:
        print(f"buildhat-conformance fuzz: {exc.args[0] if exc.args else exc}", file=sys.stderr)
        return 2
    except TargetError as exc:
        print(f"buildhat-conformance fuzz: {exc.args[0] if exc.args else exc}", file=sys.stderr)
        return 3
    except BrokenPipeError:
        # The summary's reader went away (`| head`): the findings are in their files already.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    if result.interrupted:
        return 130
    if result.not_done:
        # After the summary, so the last line says why the campaign did not count.
        print(f"buildhat-conformance fuzz: {result.not_done}", file=sys.stderr)
        return 3
    return 1 if result.findings else 0
