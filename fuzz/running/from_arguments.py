"""What ``buildhat-conformance fuzz`` does once its arguments are read: the campaign they describe, run
(over ``--jobs`` workers or one), its findings written as scripts and transcripts, the JUnit file and the
summary. The command line itself is fuzz/cli.py; ``--reproduce`` is fuzz/findings/reproduce.py."""
from __future__ import annotations

import argparse
import os
import shlex
import sys
from typing import Callable, Dict, Optional, Tuple

from ...harness.targets import make_target
from ...harness.targets.base import Target
from ...protocol.devices import DEFAULT_LAYOUT
from ..findings.explain import header_lines
from ..findings.finding_scripts import write_finding, write_junit
from ..inputs.generate import check_families
from ..inputs.grammar import grammar_for
from ..oracles.registry import oracles
from ..summary import KEPT_OPEN, Progress, print_summary
from .budget import check_limit
from .campaign import Budget, CampaignConfig, CampaignResult, Confirmed, new_seed, parse_budget, run_campaign
from .release import against_release, detect_profile, judged_note, judged_profile
from .stop_signals import StopSignals
from .target_kinds import has_tx_ring, is_fresh, is_virtual, is_wire, opener_for, scheme, sides_rings
from .worker_count import resolve_jobs

__all__ = ["run", "DEFAULT_OUT", "DEFAULT_TARGET", "OUT_LIMIT", "STOPPING"]

DEFAULT_OUT = os.path.join("reports", "fuzz")
DEFAULT_TARGET = "inprocess"
# On a wire the firmware's 8192-byte TX ring must never fill: one exchange may print this much.
OUT_LIMIT = 6000
STOPPING = ("[fuzz] stopping: keeping what was found, closing the targets, writing the findings and the "
            "JUnit file (Ctrl-C again: kill at once)")


def _config(args: argparse.Namespace, target: str, primary: Optional[Callable[[], Target]],
            secondary: Optional[Callable[[], Target]]) -> CampaignConfig:
    """The campaign ``args`` describe (openers may be given directly, e.g. planted-fault targets)."""
    virtual = is_virtual(target) and (not args.against
                                                        or is_virtual(args.against))
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
    # Read first what the target runs: a release other than --firmware stops here (exit 3).
    profile = judged_profile(open_primary, args.profile, args.fence_timeout)
    if args.against and secondary is None:
        args.against, said = against_release(args.against, profile)
        if said:
            print(f"fuzz: {said}", file=sys.stderr, flush=True)
    open_secondary, secondary_profile = secondary, None
    if open_secondary is None and args.against:
        open_secondary = opener_for(args.against)
    if open_secondary is not None:
        secondary_profile = detect_profile(open_secondary, args.fence_timeout)   # judged as itself
    devices = getattr(args, "devices", None)
    if devices is None and is_virtual(target):
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
        # A paced wire (a HAT's, or an emulator told baud=) drops output once the TX ring is full, and
        # so does the firmware in the loop (sil:), whose ring drains at 115200 baud in HAT time.
        keep_open=not virtual, out_limit=OUT_LIMIT if not virtual or has_tx_ring(target, args.against)
        else None, tx_ring=sides_rings(target, args.against, secondary), confirm=args.confirm,
        reduce_seconds=args.shrink_time, devices=devices)


def _reproduced(f: Confirmed) -> str:
    return f"{f.reproduced}/{f.attempts} replays" if f.attempts else "not replayed"


def run(args: argparse.Namespace, primary: Optional[Callable[[], Target]] = None,
        secondary: Optional[Callable[[], Target]] = None) -> Tuple[CampaignResult, Dict[str, Dict[str, str]]]:
    """The campaign of ``args``; prints its summary. Returns the result and the files written.
    Ctrl-C or SIGTERM stops the campaign, and what it found is still written
    (fuzz/running/stop_signals.py)."""
    budget = parse_budget(args.budget)
    limit = check_limit(budget, getattr(args, "check_time", None))
    target = args.target or DEFAULT_TARGET
    config = _config(args, target, primary, secondary)
    config.check_seconds = limit
    with StopSignals(say=STOPPING) as stops:
        result, chosen = _campaign(args, config, budget, stops)
        stops.hold()                  # the campaign is over: what it found is written in full
        result.interrupted = result.interrupted or stops.stopped
        return result, _report(args, config, budget, result, chosen)


def _campaign(args: argparse.Namespace, config: CampaignConfig, budget: Budget,
              stops: StopSignals) -> Tuple[CampaignResult, bool]:
    """The campaign run (over ``--jobs`` workers or here), and whether its seed was chosen at random."""
    seed, chosen = (args.seed, False) if args.seed is not None else (new_seed(), True)
    grammar = grammar_for(config.profile)
    progress = Progress(budget, len(grammar.productions), set(grammar.productions), not args.quiet)
    config.stats.on_progress = progress
    config.stats.on_note = progress.note
    database = None if args.no_database else (args.database or os.path.join(args.out, ".examples"))
    jobs = resolve_jobs(args, DEFAULT_TARGET)
    if not args.quiet:
        workers = (f", {jobs} workers" + (" (--jobs auto: one per usable CPU; --jobs 1 for one)"
                                          if getattr(args, "jobs_auto", False) else "")) if jobs > 1 else ""
        print(f"fuzz: seed {seed}" + (" (chosen at random)" if chosen else "")
              + f", budget {budget}{workers}", file=sys.stderr, flush=True)
        unknown = judged_note(config.profile)
        if unknown:
            print(f"fuzz: {unknown}", file=sys.stderr, flush=True)
    kinds = f"{scheme(args.target or DEFAULT_TARGET)}>{scheme(args.against or '')}"
    if jobs > 1:
        from .workers import run_jobs
        result, config.stats = run_jobs(config, budget, seed, jobs, database, kinds, progress, progress.note,
                                        stops)
    else:
        result = run_campaign(config, budget, seed, database, kinds)
    config.stats.examples = result.runs
    progress.end(config.stats)
    return result, chosen


def _report(args: argparse.Namespace, config: CampaignConfig, budget: Budget,
            result: CampaignResult, chosen: bool) -> Dict[str, Dict[str, str]]:
    """The findings' files, the JUnit file and the summary."""
    target = args.target or DEFAULT_TARGET
    seed, stats = result.seed, config.stats
    grammar = grammar_for(config.profile)
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
            f"reproduced: {_reproduced(f)}", *([f"checking cut short: {f.cut}"] if f.cut else []),
            *([] if f.finding.details.get("fresh", True) else [f"began on: {KEPT_OPEN}"]),
            f"reproduce: {shlex.join(reproduce_cmd)}",
            f"replay: {shlex.join(['buildhat-conformance', 'script', '--target', target, script_path])}",
            *header_lines(f.finding.details), f"finding: {f.finding.message}"]
        layout = config.devices if config.fresh else None
        files[f.oracle] = write_finding(f.finding, args.out, header, meta, layout)
    # A case per oracle, as each says (fuzz/oracles/registry.py): differential with --against, a firmware
    # in the loop's crashes and sanitizer reports where they are checked.
    against = config.open_secondary is not None
    cases = [o.name for o in oracles()
             if o.has_case(against, stats.checks, found=result.finding(o.name) is not None)]
    junit = args.junit or os.path.join(args.out, "junit.xml")
    properties = {"target": target, "against": args.against or "", "release": config.profile.name,
                  "seed": str(seed), "budget": str(budget), "inputs": str(stats.executions),
                  "lines": str(stats.lines)}
    if result.interrupted:
        properties["partial"] = "true"        # stopped by Ctrl-C or SIGTERM: what ran until then
    notes = {f.oracle: f"reproduced: {_reproduced(f)}" + (f"; checking cut short: {f.cut}" if f.cut else "")
             for f in result.findings}
    write_junit(junit, cases, [f.finding for f in result.findings], stats.checks, result.elapsed,
                properties, files, result.not_done, notes)
    # The share of the wire is a wall-clock figure: not for in-process targets (virtual time).
    wire = is_wire(target) and scheme(target) != "inprocess"
    print_summary(result, stats, grammar.productions, files, junit, seed, chosen, wire, config.out_limit)
    return files
