"""``buildhat-conformance fuzz``: grammar-based, stateful fuzzing of a target (optionally against another).

    buildhat-conformance fuzz -t inprocess:R7 --budget 30s --seed 1
    buildhat-conformance fuzz -t /dev/serial0 --against emulator --budget 500x
    buildhat-conformance fuzz --reproduce reports/fuzz/fate.script -t emulator:R7

Findings (one per oracle, confirmed by replays and reduced) are written to ``-o/--output`` (default
``reports/fuzz``; ``--out`` is its old spelling): ``<oracle>.script`` (replay with ``--reproduce``
or ``buildhat-conformance script``), ``<oracle>.<target>.jsonl`` transcripts and ``junit.xml``.
Exit status: 0 no findings, 1 findings (with ``--reproduce``: 1 reproduced, 0 not), 2 usage
errors, 3 a target that cannot be reached.
"""
from __future__ import annotations

import argparse
import os
import re
import shlex
import sys
import time
from typing import Callable, Dict, Optional, Tuple

from ..harness.cli_options import RELEASE_HELP, add_hidden_alias
from ..harness.script import ScriptError, load_script
from ..harness.targets import make_target
from ..harness.targets.base import Target, TargetError
from ..protocol.devices import DEFAULT_LAYOUT
from ..protocol.profiles import Profile, get_profile
from .campaign import Budget, CampaignConfig, CampaignResult, new_seed, parse_budget, run_campaign
from .findings import write_finding, write_junit
from .generate import FAMILIES, check_families
from .grammar import grammar_for
from .link import WIRE_BYTES_PER_S
from .replay import replay_script
from .runner import Stats

__all__ = ["add_arguments", "main", "detect_profile", "opener_for", "is_fresh", "run", "reproduce",
           "DEFAULT_TARGET"]

DEFAULT_OUT = os.path.join("reports", "fuzz")
DEFAULT_TARGET = "inprocess"
_FRESH_SCHEMES = ("inprocess", "emulator", "cmd", "sil")   # every open starts a new, freshly booted HAT
_VIRTUAL_SCHEMES = ("inprocess", "sil")     # HAT time, not wall time: the in-process emulator, the firmware
# A finding whose run began on a target that earlier runs left (kept open) says so.
_KEPT_OPEN = "a target earlier runs had left open; a freshly started one may not reproduce it"
# On a wire the firmware's 8192-byte TX ring must never fill: one exchange may print this much.
OUT_LIMIT = 6000


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
                        help="replays of a failing run before it is reported (and with --reproduce); "
                             "default 3")
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
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    from ..harness.lab.selection import add_lab_arguments

    add_lab_arguments(parser, "one campaign per place, into -o/<place>/")


def _scheme(url: str) -> str:
    return url.split(":", 1)[0].split("?", 1)[0].lower()


def _all_in_process(target: str, against: Optional[str]) -> bool:
    return _scheme(target) == "inprocess" and (not against or _scheme(against) == "inprocess")


def is_fresh(url: str) -> bool:
    return _scheme(url) in _FRESH_SCHEMES


def opener_for(url: str) -> Callable[[], Target]:
    make_target(url)   # fail early with the registry's message for a bad URL
    return lambda: make_target(url)


def detect_profile(open_target: Callable[[], Target], timeout: float = 2.0) -> Profile:
    """The release a target runs, from its answer to ``version`` (via the harness session)."""
    from ..harness.session import Session
    session = Session(open_target())
    try:
        session.open(timeout=timeout)
        if session.in_bootloader:
            raise TargetError("the target is in its bootloader; the fuzzer needs the firmware running")
        if session.profile is None:
            raise TargetError("the target did not say which firmware it runs (no answer to `version`)")
        return session.profile
    finally:
        session.close()



class Progress:
    """The progress line on stderr: rewritten in place on a terminal (at most twice a second),
    else a plain line every few seconds (a log must not fill with carriage returns)."""

    def __init__(self, budget: Budget, grammar_size: int, productions: set, enabled: bool,
                 stream=None, every: float = 5.0):  # type: ignore[no-untyped-def]
        self.stream = stream or sys.stderr
        self.start = time.monotonic()
        self.last = self.start
        self.budget = budget
        self.grammar_size = grammar_size
        self.productions = productions
        self.enabled = enabled
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.every = 0.5 if self.tty else every

    def line(self, stats: Stats) -> str:
        # The budget counts fuzzing time; confirming and reducing findings come on top.
        el = max(time.monotonic() - self.start - stats.checking_s - stats.startup_s, 1e-9)
        spent = f"{el:.0f}/{self.budget.seconds:g} s" if self.budget.seconds is not None else \
            f"{stats.examples}/{self.budget.examples} runs, {el:.0f} s"
        if stats.checking_s >= 1:
            spent += f" (+{stats.checking_s:.0f} s confirming findings)"
        return (f"[fuzz] {spent}: {stats.executions} inputs, {stats.lines / el:.0f} lines/s, "
                f"productions {len(stats.productions & self.productions)}/{self.grammar_size}, "
                f"response classes {len(stats.responses)}")

    def __call__(self, stats: Stats) -> None:
        now = time.monotonic()
        if self.enabled and now - self.last >= self.every:
            self.last = now
            if self.tty:
                self.stream.write("\r" + self.line(stats) + " " * 4)
            else:
                self.stream.write(self.line(stats) + "\n")
            self.stream.flush()

    def note(self, text: str) -> None:
        """A plain line (on a terminal, below the progress line)."""
        if self.enabled:
            self.stream.write(("\n" if self.tty else "") + f"[fuzz] {text}\n")
            self.stream.flush()

    def end(self, stats: Stats) -> None:
        if self.enabled and self.tty:
            self.stream.write("\r" + self.line(stats) + "\n")
            self.stream.flush()


def _config(args: argparse.Namespace, target: str, primary: Optional[Callable[[], Target]],
            secondary: Optional[Callable[[], Target]]) -> CampaignConfig:
    """The campaign ``args`` describe (openers may be given directly, e.g. planted-fault targets)."""
    virtual = _scheme(target) in _VIRTUAL_SCHEMES and (not args.against
                                                        or _scheme(args.against) in _VIRTUAL_SCHEMES)
    if args.fence_timeout is None:
        args.fence_timeout = 0.3 if virtual else 2.0
    families = tuple(f.strip() for f in args.families.split(",") if f.strip())
    check_families(families)
    try:
        waits = tuple(int(w) for w in args.waits.split(",") if w.strip())
    except ValueError:
        raise ValueError(f"--waits takes milliseconds separated by commas, got {args.waits!r}") from None
    if args.steps < 1 or args.batch < 1 or args.confirm < 0:
        raise ValueError("--steps and --batch take a positive number, --confirm zero or more")
    open_primary = primary or opener_for(target)
    profile = get_profile(args.profile) if args.profile else detect_profile(open_primary, args.fence_timeout)
    open_secondary, secondary_profile = secondary, None
    if open_secondary is None and args.against:
        open_secondary = opener_for(args.against)
    if open_secondary is not None:
        secondary_profile = detect_profile(open_secondary, args.fence_timeout)
    devices = getattr(args, "devices", None)
    if devices is None and _scheme(target) in _VIRTUAL_SCHEMES:
        layout = dict(DEFAULT_LAYOUT)
        layout.update(getattr(make_target(target), "devices", {}))
        devices = layout
    return CampaignConfig(
        open_primary=open_primary, profile=profile, open_secondary=open_secondary,
        secondary_profile=secondary_profile, families=families, steps=args.steps, batch=args.batch,
        waits=waits, fence_s=args.fence_timeout,
        # In HAT time a wait costs only CPU; on a real-time wire it idles the link.
        wait_share=0.1 if virtual else 0.01,
        fresh=is_fresh(target) and (not args.against or is_fresh(args.against)),
        # Targets that take seconds to boot stay open from run to run (the prelude resets them).
        # Only the in-process emulator empties its TX ring at once; the firmware in the loop (sil:)
        # drains it at 115200 baud as on a HAT, so its ring can fill.
        keep_open=not virtual, out_limit=None if _all_in_process(target, args.against) else OUT_LIMIT,
        confirm=args.confirm,
        reduce_seconds=args.shrink_time, devices=devices)


def run(args: argparse.Namespace, primary: Optional[Callable[[], Target]] = None,
        secondary: Optional[Callable[[], Target]] = None) -> Tuple[CampaignResult, Dict[str, Dict[str, str]]]:
    """The campaign of ``args``; prints its summary. Returns the result and the files written."""
    budget = parse_budget(args.budget)
    target = args.target or DEFAULT_TARGET
    config = _config(args, target, primary, secondary)
    seed, chosen = (args.seed, False) if args.seed is not None else (new_seed(), True)
    grammar = grammar_for(config.profile)
    progress = Progress(budget, len(grammar.productions), set(grammar.productions), not args.quiet)
    config.stats.on_progress = progress
    config.stats.on_note = progress.note
    database = None if args.no_database else (args.database or os.path.join(args.out, ".examples"))
    if not args.quiet:
        print(f"fuzz: seed {seed}" + (" (chosen at random)" if chosen else "") + f", budget {budget}",
              file=sys.stderr, flush=True)
    result = run_campaign(config, budget, seed, database, f"{_scheme(target)}>{_scheme(args.against or '')}")
    stats = config.stats
    stats.examples = result.runs
    progress.end(stats)
    files: Dict[str, Dict[str, str]] = {}
    other = config.secondary_profile
    release = config.profile.name + (f" / {other.name}" if other else "")
    meta = {"firmware": config.profile.version_string, "target": target, "tool": "buildhat-conformance fuzz",
            "seed": seed}
    for f in result.findings:
        script_path = os.path.join(args.out, f"{f.oracle}.script")
        reproduce_cmd = ["buildhat-conformance", "fuzz", "--reproduce", script_path, "--target", target]
        if args.against:
            reproduce_cmd += ["--against", args.against]
        header = [f"target: {target}"] + ([f"against: {args.against}"] if args.against else []) + [
            f"release: {release}", f"seed: {seed}  run seed: {f.run_seed}  budget: {budget}",
            f"reproduced: {f.reproduced}/{f.attempts} replays",
            *([] if f.finding.details.get("fresh", True) else [f"began on: {_KEPT_OPEN}"]),
            f"reproduce: {shlex.join(reproduce_cmd)}",
            f"replay: {shlex.join(['buildhat-conformance', 'script', '--target', target, script_path])}",
            f"finding: {f.finding.message[:300]}"]
        layout = config.devices if config.fresh else None
        files[f.oracle] = write_finding(f.finding, args.out, header, meta, layout)
    oracles = ["liveness", "fate", "state", "hygiene"] + (["differential"] if config.open_secondary else [])
    junit = args.junit or os.path.join(args.out, "junit.xml")
    write_junit(junit, oracles, [f.finding for f in result.findings], stats.checks, result.elapsed,
                {"target": target, "against": args.against or "", "release": config.profile.name,
                 "seed": str(seed), "budget": str(budget), "inputs": str(stats.executions),
                 "lines": str(stats.lines)}, files)
    _summary(result, stats, grammar.productions, files, junit, target, seed, chosen)
    return result, files


def _summary(result: CampaignResult, stats: Stats, productions, files, junit: str, target: str,  # type: ignore[no-untyped-def]
             seed: int, chosen: bool) -> None:
    el = max(result.elapsed, 1e-9)
    apart = ([f"{result.checking:.1f} s confirming findings"] if result.checking >= 0.05 else []) + \
        ([f"{stats.startup_s:.1f} s starting targets"] if stats.startup_s >= 0.05 else [])
    checking = f" (and {', '.join(apart)})" if apart else ""
    print(f"fuzz: {result.runs} runs, {stats.executions} inputs ({stats.lines} lines, "
          f"{stats.lines / el:.0f} lines/s) in {result.elapsed:.1f} s{checking}")
    if result.cpu > 0:
        # On a shared machine the wall-clock rate is what others leave over; this is the fuzzer's own.
        print(f"  this process: {result.cpu:.1f} s of CPU, "
              f"{stats.lines / result.cpu:.0f} lines per CPU second")
    if _scheme(target) not in _VIRTUAL_SCHEMES:
        sent, recv = stats.sent_bytes / el, stats.recv_bytes / el
        print(f"  wire: sent {sent:.0f} B/s, received {recv:.0f} B/s; the busier direction carries "
              f"{100 * max(sent, recv) / WIRE_BYTES_PER_S:.0f} % of what 115200 baud can")
    print(f"  seed: {seed}" + (f" (chosen at random; --seed {seed} repeats this campaign)" if chosen else ""))
    missing = sorted(set(productions) - stats.productions)
    more = " ..." if len(missing) > 12 else ""
    print(f"  grammar productions covered: {len(set(productions) & stats.productions)}/{len(productions)}"
          + (f" (not reached: {', '.join(missing[:12])}{more})" if missing else ""))
    print(f"  response classes seen: {', '.join(sorted(stats.responses))}")
    print("  checks: " + ", ".join(f"{k} {v}" for k, v in sorted(stats.checks.items()))
          + (f"; {stats.liveness_only} step(s) judged on liveness only (debug bit 1's raw trace)"
             if stats.liveness_only else ""))
    if stats.left_out:
        print(f"  {stats.left_out} input(s) not sent: the answer of each alone is over {OUT_LIMIT} bytes, "
              f"more than the TX ring keeps on this wire")
    if not result.findings:
        print("  no findings")
    for f in result.findings:
        again = f", seen {f.also_seen} more time(s)" if f.also_seen else ""
        print(f"  FINDING [{f.oracle}] (reproduced {f.reproduced}/{f.attempts}{again}): "
              f"{f.finding.message[:400]}")
        if not f.finding.details.get("fresh", True):
            print(f"      began on {_KEPT_OPEN}")
        for what, path in files.get(f.oracle, {}).items():
            print(f"      {what}: {path}")
    for finding, tries in result.unconfirmed:
        print(f"  unconfirmed [{finding.oracle}] (0/{tries} replays failed again; not reported): "
              f"{finding.message[:200]}")
    print(f"  junit: {junit}")
    if result.interrupted:
        print("  interrupted (Ctrl-C): the figures and findings above cover what ran")


_HEADER = re.compile(r"^;; (target|against|release|began on): (.*)$", re.M)
_ORACLE_OF = re.compile(r"^fuzz finding \((\w+)\)")


def reproduce(args: argparse.Namespace, primary: Optional[Callable[[], Target]] = None,
              secondary: Optional[Callable[[], Target]] = None) -> int:
    """``--reproduce FINDING``: replay its script ``--confirm`` times (at least once)."""
    path = args.reproduce
    try:
        with open(path, encoding="utf-8") as fh:
            recorded = dict(_HEADER.findall(fh.read()))
        script = load_script(path)
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror}") from None
    target = args.target or recorded.get("target") or DEFAULT_TARGET
    against = args.against or recorded.get("against")
    fence_s = args.fence_timeout if args.fence_timeout is not None else (
        0.3 if _scheme(target) in _VIRTUAL_SCHEMES else 2.0)
    open_primary = primary or opener_for(target)
    profile = get_profile(args.profile) if args.profile else detect_profile(open_primary, fence_s)
    other = None
    if secondary is not None or against:
        open_secondary = secondary or opener_for(against or "")
        other = (open_secondary, detect_profile(open_secondary, fence_s))
    # A finding's script names its oracle; only that failure reproduces it (any, for other scripts).
    named = _ORACLE_OF.search(script.name or "")
    oracle = named.group(1) if named else None
    attempts = max(1, args.confirm)
    hits, first, others = 0, None, []
    for _ in range(attempts):
        finding = replay_script(script, open_primary, profile, fence_s, fresh=is_fresh(target), against=other)
        if finding is None:
            continue
        if oracle is None or finding.oracle == oracle:
            hits += 1
            first = first or finding
        else:
            others.append(finding)
    where = f"{target}" + (f" against {against}" if against else "")
    if first is not None:
        print(f"reproduced ({hits}/{attempts} replays) on {where}: [{first.oracle}] {first.message[:400]}")
    else:
        print(f"not reproduced (0/{attempts} replays) on {where}")
        if "began on" in recorded and is_fresh(target):
            print(f"  the finding began on {recorded['began on']}")
    for f in others[:1]:
        print(f"  {len(others)} replay(s) failed otherwise, first: [{f.oracle}] {f.message[:300]}")
    return 1 if first is not None else 0


def main(args: argparse.Namespace) -> int:
    from .lab_campaigns import hold_for_campaign, run_places

    # labgrid places are held for the whole campaign, or all campaigns (fuzz/lab_campaigns.py)
    give_back = hold_for_campaign(args)
    try:
        if args.places:
            from ..harness.cli_options import check_writable

            check_writable(args.out, "-o", folder=True)
            return run_places(args)
        return _main(args)
    finally:
        if give_back is not None:
            give_back()


def _main(args: argparse.Namespace) -> int:
    from ..harness.cli_options import check_writable
    from ..harness.preflight import check_release, checked_target

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
    return 1 if result.findings else 0
