"""``buildhat-conformance fuzz``: grammar-based, stateful fuzzing of a target (optionally against another).

    buildhat-conformance fuzz -t inprocess:R7 --budget 30s --seed 1
    buildhat-conformance fuzz -t /dev/serial0 --against emulator --budget 500x
    buildhat-conformance fuzz --reproduce reports/fuzz/fate.script -t emulator:R7
    buildhat-conformance fuzz -t sil:~/buildhat/firmware-pico --against inprocess --jobs 2   # fuzz/jobs.py

Findings (one per oracle, confirmed by replays and reduced) are written to ``-o/--output`` (default
``reports/fuzz``; ``--out`` is its old spelling): ``<oracle>.script`` (replay with ``--reproduce``
or ``buildhat-conformance script``), ``<oracle>.<target>.jsonl`` transcripts and ``junit.xml``.
Exit status: 0 no findings, 1 findings (with ``--reproduce``: 1 reproduced, 0 not), 2 usage
errors, 3 a campaign that could not do its job
(a target that cannot be reached, answers as another release than ``--firmware``, or took no input).
"""
from __future__ import annotations

import argparse
import os
import re
import shlex
import sys
from typing import Callable, Dict, Optional, Tuple, Union
from urllib.parse import parse_qs, urlsplit

from ..harness.cli_options import RELEASE_HELP, add_hidden_alias
from ..harness.targets import make_target
from ..harness.targets.base import Target, TargetError
from ..protocol.devices import DEFAULT_LAYOUT
from ..transcripts.script import ScriptError, load_script
from .campaign import CampaignConfig, CampaignResult, new_seed, parse_budget, run_campaign
from .explain import header_lines
from .findings import write_finding, write_junit
from .generate import FAMILIES, check_families
from .grammar import grammar_for
from .release import detect_profile, judged_profile
from .replay import replay_script
from .summary import KEPT_OPEN, Progress, print_summary

__all__ = ["add_arguments", "main", "detect_profile", "opener_for", "is_fresh", "run", "reproduce",
           "DEFAULT_TARGET", "check_jobs", "fresh_boot_options"]

DEFAULT_OUT = os.path.join("reports", "fuzz")
DEFAULT_TARGET = "inprocess"
_FRESH_SCHEMES = ("inprocess", "emulator", "cmd", "sil")   # every open starts a new, freshly booted HAT
_VIRTUAL_SCHEMES = ("inprocess", "sil")     # HAT time, not wall time: the in-process emulator, the firmware
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
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="run N campaign workers at once, each with targets of its own, into one "
                             "summary (targets started anew at each open: inprocess, emulator, cmd:, "
                             "sil:; for several real HATs use --places); default 1")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    from ..harness.lab.selection import add_lab_arguments

    add_lab_arguments(parser, "one campaign per place, into -o/<place>/")


def _scheme(url: str) -> str:
    return url.split(":", 1)[0].split("?", 1)[0].lower()


def is_fresh(url: str) -> bool:
    return _scheme(url) in _FRESH_SCHEMES


def is_wire(url: str) -> bool:
    """A paced or real 115200-baud wire: a serial port or socket, or an emulator told ``baud=``
    (a pty, a pipe or the in-process emulator unpaced move bytes as fast as they come)."""
    scheme = _scheme(url)
    if scheme in ("cmd", "loop"):
        return False
    if scheme == "sil":              # HAT time, unless paced to the wall clock (speed=)
        return "speed=" in url
    if scheme in ("inprocess", "emulator"):
        target = make_target(url)
        return bool(getattr(target, "baud", None) or getattr(target, "wire_baud", None))
    return True


def _one_ring(url: str) -> bool:
    return is_wire(url) or _scheme(url) not in ("inprocess", "emulator")


def has_tx_ring(url: str, against: Optional[str] = None) -> bool:
    """Output may meet a full TX ring (fuzz/txring.py): any target but our emulator unpaced, whose
    output never waits (a `cmd:` target may be firmware behind a pipe, with a ring of its own)."""
    return _one_ring(url) or bool(against and _one_ring(against))


def ring_sides(url: str, against: Optional[str] = None) -> Tuple[bool, ...]:
    """:func:`has_tx_ring` per side, target first: only a side with a ring pauses for it."""
    return (_one_ring(url),) + ((_one_ring(against),) if against else ())


def _sides_rings(target: str, against: Optional[str], secondary: Optional[Callable[[], Target]]
                 ) -> Union[bool, Tuple[bool, ...]]:
    """The runner's ``tx_ring``: per side when both URLs are known (a second target given as an
    opener alone, with no URL, shares the first's)."""
    if secondary is not None and not against:
        return has_tx_ring(target)
    return ring_sides(target, against)


def opener_for(url: str) -> Callable[[], Target]:
    make_target(url)   # fail early with the registry's message for a bad URL
    options = fresh_boot_options(url)
    return lambda: make_target(url, **options)


def fresh_boot_options(url: str) -> Dict[str, bool]:
    """What makes a new target of ``url`` start as the fuzzer takes every fresh open to start:
    booted, its layout's devices established (``inprocess`` and ``sil:`` open so by default).
    The ``emulator`` process starts at power-on unless told ``booted``, and its devices take
    about 0.8 s of HAT time to connect: a differential run's first `list` (sil finding, seed 5)
    compared that with a booted side. A URL that says ``booted`` or ``bootloader`` is obeyed."""
    if _scheme(url) != "emulator":
        return {}
    query = parse_qs(urlsplit("x:" + url[len("emulator"):].lstrip(":")).query, keep_blank_values=True)
    return {} if "booted" in query or "bootloader" in query else {"booted": True}


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
    # Read first what the target runs: a release other than --firmware stops here (exit 3).
    profile = judged_profile(open_primary, args.profile, args.fence_timeout)
    open_secondary, secondary_profile = secondary, None
    if open_secondary is None and args.against:
        open_secondary = opener_for(args.against)
    if open_secondary is not None:
        secondary_profile = detect_profile(open_secondary, args.fence_timeout)   # judged as itself
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
        # A paced wire (a HAT's, or an emulator told baud=) drops output once the TX ring is full, and
        # so does the firmware in the loop (sil:), whose ring drains at 115200 baud in HAT time.
        keep_open=not virtual, out_limit=OUT_LIMIT if not virtual or has_tx_ring(target, args.against)
        else None, tx_ring=_sides_rings(target, args.against, secondary), confirm=args.confirm,
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
    scheme = f"{_scheme(target)}>{_scheme(args.against or '')}"
    jobs = getattr(args, "jobs", 1) or 1
    if jobs > 1:
        from .jobs import run_jobs
        result, config.stats = run_jobs(config, budget, seed, jobs, database, scheme, progress, progress.note)
    else:
        result = run_campaign(config, budget, seed, database, scheme)
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
            *([] if f.finding.details.get("fresh", True) else [f"began on: {KEPT_OPEN}"]),
            f"reproduce: {shlex.join(reproduce_cmd)}",
            f"replay: {shlex.join(['buildhat-conformance', 'script', '--target', target, script_path])}",
            *header_lines(f.finding.details), f"finding: {f.finding.message}"]
        layout = config.devices if config.fresh else None
        files[f.oracle] = write_finding(f.finding, args.out, header, meta, layout)
    oracles = ["liveness", "fate", "state", "hygiene"] + (["differential"] if config.open_secondary else [])
    junit = args.junit or os.path.join(args.out, "junit.xml")
    write_junit(junit, oracles, [f.finding for f in result.findings], stats.checks, result.elapsed,
                {"target": target, "against": args.against or "", "release": config.profile.name,
                 "seed": str(seed), "budget": str(budget), "inputs": str(stats.executions),
                 "lines": str(stats.lines)}, files, result.not_done)
    # The share of the wire is a wall-clock figure: not for in-process targets (virtual time).
    wire = is_wire(target) and _scheme(target) != "inprocess"
    print_summary(result, stats, grammar.productions, files, junit, seed, chosen, wire, config.out_limit)
    return result, files


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
    profile = judged_profile(open_primary, args.profile, fence_s)
    other = None
    if secondary is not None or against:
        open_secondary = secondary or opener_for(against or "")
        other = (open_secondary, detect_profile(open_secondary, fence_s))
    # A finding's script names its oracle; only that failure reproduces it (any, for other scripts).
    named = _ORACLE_OF.search(script.name or "")
    oracle = named.group(1) if named else None
    attempts = max(1, args.confirm)
    hits, first, others, refused = 0, None, [], []
    for _ in range(attempts):
        finding = replay_script(script, open_primary, profile, fence_s, fresh=is_fresh(target), against=other,
                                tx_ring=_sides_rings(target, against, secondary))
        if finding is None:
            continue
        if finding.details.get("prelude"):
            refused.append(finding)           # the target did not take the prelude: proves nothing
        elif oracle is None or finding.oracle == oracle:
            hits += 1
            first = first or finding
        else:
            others.append(finding)
    where = f"{target}" + (f" against {against}" if against else "")
    if len(refused) == attempts:
        raise TargetError(f"could not replay on {where}: the target did not take the prelude "
                          f"({refused[0].message})")
    if first is not None:
        print(f"reproduced ({hits}/{attempts} replays) on {where}: [{first.oracle}] {first.message}")
    else:
        print(f"not reproduced (0/{attempts} replays) on {where}")
        if "began on" in recorded and is_fresh(target):
            print(f"  the finding began on {recorded['began on']}")
    for f in others[:1]:
        print(f"  {len(others)} replay(s) failed otherwise, first: [{f.oracle}] {f.message[:300]}")
    return 1 if first is not None else 0


def main(args: argparse.Namespace) -> int:
    from .lab_campaigns import hold_for_campaign, run_places

    check_jobs(args)
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


def check_jobs(args: argparse.Namespace) -> None:
    """``--jobs N`` needs targets that start a new HAT at every open (one per worker)."""
    from ..harness.cli_options import UsageError

    jobs = getattr(args, "jobs", 1)
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
    if result.not_done:
        # After the summary, so the last line says why the campaign did not count.
        print(f"buildhat-conformance fuzz: {result.not_done}", file=sys.stderr)
        return 3
    return 1 if result.findings else 0
