"""``buildhat-conformance fuzz``: grammar-based, stateful fuzzing of a target (optionally against another).

    buildhat-conformance fuzz --target inprocess:R7 --budget 30s --seed 1
    buildhat-conformance fuzz --target /dev/serial0 --against emulator --budget 5000

Findings (one shrunk example per oracle) are written to ``--out`` (default ``reports/fuzz``):
``<oracle>.script`` (replay with ``buildhat-conformance script``), ``<oracle>.<target>.jsonl``
transcripts and ``junit.xml``. Exit status: 0 no findings, 1 findings, 2 usage or target errors.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Callable, Dict, List, Optional, Tuple

from ..harness.script import load_script
from ..harness.targets import make_target
from ..harness.targets.base import Target, TargetError
from ..protocol.devices import DEFAULT_LAYOUT
from ..protocol.profiles import Profile, get_profile
from .campaign import CampaignResult, parse_budget, run_campaign
from .findings import write_finding, write_junit
from .grammar import grammar_for
from .machine import FuzzConfig
from .reduce import reduce_finding
from .runner import Stats
from .strategies import FAMILIES

__all__ = ["add_arguments", "main", "detect_profile", "opener_for", "is_fresh", "run"]

DEFAULT_OUT = os.path.join("reports", "fuzz")
_FRESH_SCHEMES = ("inprocess", "emulator", "cmd")   # every open starts a new, freshly booted HAT


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--target", default="inprocess", help="target URL (default: inprocess, the emulator "
                        "in this process in virtual time)")
    parser.add_argument("--against", default=None, metavar="URL",
                        help="differential mode: send the same input to this second target and compare")
    parser.add_argument("--budget", default="30s",
                        help="30s / 2m (wall clock) or 5000 (examples); default 30s")
    parser.add_argument("--seed", type=int, default=None, help="seed for a reproducible campaign")
    parser.add_argument("--database", default=None, metavar="PATH",
                        help="Hypothesis example database (default: <out>/.hypothesis)")
    parser.add_argument("--no-database", action="store_true", help="do not read or save examples")
    parser.add_argument("--out", default=DEFAULT_OUT, help=f"where findings go (default {DEFAULT_OUT})")
    parser.add_argument("--junit", default=None, help="JUnit file (default: <out>/junit.xml)")
    parser.add_argument("--profile", default=None, help="release to assume (R1..R7); default: ask `version`")
    parser.add_argument("--families", default=",".join(FAMILIES),
                        help=f"input families, comma-separated (default: {','.join(FAMILIES)})")
    parser.add_argument("--steps", type=int, default=40, help="steps per example (default 40)")
    parser.add_argument("--batch", type=int, default=None,
                        help="at most this many inputs sent back to back in one step (default: 4 in-process, "
                             "8 over a link)")
    parser.add_argument("--waits", default="10,60,300",
                        help="HAT milliseconds the wait rule may let pass, comma-separated; empty: no "
                             "wait rule (default 10,60,300)")
    parser.add_argument("--fence-timeout", type=float, default=None,
                        help="HAT seconds a fence may take beyond the time its output needs on the wire "
                             "(default: 0.3 in-process, where nothing is slower than the wire; else 2)")
    parser.add_argument("--shrink-time", type=float, default=60.0,
                        help="seconds Hypothesis may spend shrinking (then whole steps are dropped by "
                             "replaying the script; default 60)")
    parser.add_argument("--quiet", action="store_true", help="no live progress line")


def _scheme(url: str) -> str:
    return url.split(":", 1)[0].split("?", 1)[0].lower()


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
        profile = session.profile
        if session.in_bootloader or profile is None:
            raise TargetError("the target is in its bootloader; the fuzzer needs the firmware running")
        return profile
    finally:
        session.close()


class Progress:
    """The live progress line (stderr), at most twice a second."""

    def __init__(self, grammar_size: int, enabled: bool):
        self.start = time.monotonic()
        self.last = 0.0
        self.grammar_size = grammar_size
        self.enabled = enabled
        self.findings = 0

    def line(self, stats: Stats) -> str:
        el = max(time.monotonic() - self.start, 1e-9)
        covered = len(stats.productions & _KNOWN[0])
        return (f"[fuzz] {stats.examples} runs, {stats.executions} inputs, {stats.lines / el:.0f} lines/s, "
                f"{self.findings} findings, productions {covered}/{self.grammar_size}, "
                f"response classes {len(stats.responses)}")

    def __call__(self, stats: Stats) -> None:
        now = time.monotonic()
        if self.enabled and now - self.last >= 0.5:
            self.last = now
            sys.stderr.write("\r" + self.line(stats) + " " * 4)
            sys.stderr.flush()


_KNOWN: List[set] = [set()]


def run(args: argparse.Namespace, primary: Optional[Callable[[], Target]] = None,
        secondary: Optional[Callable[[], Target]] = None) -> Tuple[CampaignResult, Dict[str, Dict[str, str]]]:
    """The campaign of ``args`` (openers may be given directly, e.g. planted-fault targets)."""
    budget = parse_budget(args.budget)
    if args.fence_timeout is None:
        args.fence_timeout = 0.3 if _scheme(args.target) == "inprocess" and (
            not args.against or _scheme(args.against) == "inprocess") else 2.0
    families = tuple(f.strip() for f in args.families.split(",") if f.strip())
    try:
        waits = tuple(int(w) for w in args.waits.split(",") if w.strip())
    except ValueError:
        raise ValueError(f"--waits takes milliseconds separated by commas, got {args.waits!r}") from None
    open_primary = primary or opener_for(args.target)
    profile = get_profile(args.profile) if args.profile else detect_profile(open_primary, args.fence_timeout)
    open_secondary, secondary_profile = secondary, None
    if open_secondary is None and args.against:
        open_secondary = opener_for(args.against)
    if open_secondary is not None:
        secondary_profile = detect_profile(open_secondary, args.fence_timeout)
    grammar = grammar_for(profile)
    _KNOWN[0] = set(grammar.productions)
    fresh = is_fresh(args.target) and (not args.against or is_fresh(args.against))
    batch = args.batch if args.batch is not None else (4 if _scheme(args.target) == "inprocess" else 8)
    devices = getattr(args, "devices", None)
    if devices is None and _scheme(args.target) == "inprocess":
        layout = dict(DEFAULT_LAYOUT)
        layout.update(getattr(make_target(args.target), "devices", {}))
        devices = layout
    progress = Progress(len(grammar.productions), not args.quiet)
    stats = Stats(on_progress=progress)
    config = FuzzConfig(open_primary=open_primary, profile=profile, open_secondary=open_secondary,
                        secondary_profile=secondary_profile, families=families, batch=batch, waits=waits,
                        fence_s=args.fence_timeout, fresh=fresh,
                        labels=("target", "against"), stats=stats, devices=devices)
    database = None if args.no_database else (args.database or os.path.join(args.out, ".hypothesis"))
    result = run_campaign(config, budget, seed=args.seed, database=database, steps=args.steps,
                          database_key=f"{_scheme(args.target)}>{_scheme(args.against or '')}",
                          shrink_seconds=args.shrink_time)
    progress.findings = len(result.findings)
    if progress.enabled:
        sys.stderr.write("\r" + progress.line(stats) + "\n")
    files: Dict[str, Dict[str, str]] = {}
    header = [f"target: {args.target}" + (f"  against: {args.against}" if args.against else ""),
              f"release: {profile.name}" + (f" / {secondary_profile.name}" if secondary_profile else ""),
              f"seed: {args.seed}  budget: {args.budget}",
              f"replay: buildhat-conformance script --target {args.target} <this file>"]
    meta = {"firmware": profile.version_string, "target": args.target, "tool": "buildhat-conformance fuzz",
            "seed": args.seed}
    against = (open_secondary, secondary_profile) \
        if open_secondary is not None and secondary_profile is not None else None
    for i, f in enumerate(result.findings):
        files[f.oracle] = write_finding(f, args.out, header + [f"finding: {f.message[:300]}"], meta, devices)
        if fresh and "script" in files[f.oracle]:
            script, reduced = reduce_finding(load_script(files[f.oracle]["script"]), f, open_primary, profile,
                                             args.fence_timeout, against=against)
            if reduced is not f:
                result.findings[i] = reduced
                note = [f"finding: {reduced.message[:300]}"]
                files[f.oracle] = write_finding(reduced, args.out, header + note, meta, devices)
    oracles = ["liveness", "fate", "state", "hygiene"] + (["differential"] if open_secondary else [])
    junit = args.junit or os.path.join(args.out, "junit.xml")
    write_junit(junit, oracles, result.findings, stats.checks, result.elapsed,
                {"target": args.target, "against": args.against or "", "release": profile.name,
                 "seed": str(args.seed), "budget": args.budget, "inputs": str(stats.executions),
                 "lines": str(stats.lines)}, files)
    _summary(result, stats, grammar.productions, files, junit)
    return result, files


def _summary(result: CampaignResult, stats: Stats, productions, files, junit: str) -> None:
    el = max(result.elapsed, 1e-9)
    print(f"fuzz: {stats.examples} runs, {stats.executions} inputs ({stats.lines} lines, "
          f"{stats.lines / el:.0f} lines/s) in {result.elapsed:.1f} s")
    missing = sorted(set(productions) - stats.productions)
    more = " ..." if len(missing) > 12 else ""
    print(f"  grammar productions covered: {len(set(productions) & stats.productions)}/{len(productions)}"
          + (f" (not reached: {', '.join(missing[:12])}{more})" if missing else ""))
    print(f"  response classes seen: {', '.join(sorted(stats.responses))}")
    print("  checks: " + ", ".join(f"{k} {v}" for k, v in sorted(stats.checks.items())))
    if not result.findings:
        print("  no findings")
    for f in result.findings:
        print(f"  FINDING [{f.oracle}]{' (flaky)' if f.oracle in result.flaky else ''}: {f.message[:400]}")
        for what, path in files.get(f.oracle, {}).items():
            print(f"      {what}: {path}")
    print(f"  junit: {junit}")


def main(args: argparse.Namespace) -> int:
    try:
        result, _files = run(args)
    except (TargetError, ValueError, KeyError) as exc:
        print(f"buildhat-conformance fuzz: {exc.args[0] if exc.args else exc}", file=sys.stderr)
        return 2
    return 1 if result.findings else 0
