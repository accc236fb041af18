"""``buildhat-conformance bench`` / ``make bench``: every figure with its goal.

Measurements are grouped: one run of a group yields a dict from which several figures take
their sample. Each group runs several times and each figure reports the median. Nothing
here fails on a number: the machines are shared and noisy; the table says which goals were
met on this run. A group that cannot run (a part missing, an error) blanks its figures and
says why in the note column.
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import time
from typing import Callable, List, Optional, Tuple

from ..plumbing.cli_options import add_hidden_alias
from ..plumbing.package_version import __version__
from .figures import Figure, render_table, write_json

# (name, measure, [(figure, key)], most runs or None). A group whose one run takes minutes
# (the suite at real time is over 200 s of waiting that no machine can shorten) runs once.
Group = Tuple[str, Callable[[], dict], List[Tuple[Figure, str]], Optional[int]]

# --quick: the suite on a subset (one file, with waits of its own so the overhead figure means
# something) instead of all of it.
QUICK_SUITE = "test_select"


def _groups(quick: bool) -> List[Group]:
    from . import (
        cost,
        fidelity,
        firmware_load,
        host_write,
        lab,
        same_world,
        sil,
        suite,
        target_faults,
        throughput,
    )

    lines = 100_000 if quick else 1_000_000
    # Seconds per measurement window: three 3 s windows give medians as steady as 5 s ones did
    # (the run-to-run spread is the machine's load, not the window); most of `make bench`'s
    # six and a half minutes is the real-time suite's own waiting.
    secs = 1.5 if quick else 3.0
    fuzz_secs = 5.0 if quick else 15.0     # a campaign's figure includes its start-up
    k = QUICK_SUITE if quick else None
    scaled = f"--speed {suite.SCALED_SPEED:g}"
    return [
        ("suite at real time", lambda: suite.suite_run(scaled=False, keyword=k), [
            (Figure("suite wall time, real time", "s"), "wall_s"),
            (Figure("suite mandatory waits (sum)", "s"), "waits_s"),
            (Figure("suite overhead above mandatory waits", "%", "<= 10 %", target=10.0),
             "overhead_pct")], 1),
        ("suite scaled", lambda: suite.suite_run(scaled=True, keyword=k), [
            (Figure(f"suite wall time, {scaled}", "s", "<= 20 s", target=20.0), "wall_s"),
            (Figure(f"suite overhead above mandatory waits, {scaled}", "%"), "overhead_pct")], 2),
        # The fuzz figures are the `fuzz` command's own summary (bench/throughput.py).
        ("fuzz in-process", lambda: throughput.inprocess(seconds=fuzz_secs), [
            (Figure("fuzz lines/s in-process", "lines/s", ">= 5,000", "higher", 5000.0),
             "lines_per_s"),
            # What the command printed as its own CPU rate: the wall figure on an idle machine.
            (Figure("fuzz lines per CPU second in-process", "lines/s"), "lines_per_cpu_s")], None),
        ("fuzz over a pty", lambda: throughput.over_pty(seconds=fuzz_secs), [
            (Figure("fuzz lines/s over a pty", "lines/s", ">= 1,000", "higher", 1000.0),
             "lines_per_s")], None),
        ("fuzz over 3 ptys at once", lambda: throughput.parallel_ptys(3, seconds=fuzz_secs), [
            (Figure("fuzz lines/s, 3 emulators in parallel (sum)", "lines/s"), "lines_per_s")], 1),
        ("fuzz at 115200 baud", lambda: throughput.baud_paced(seconds=fuzz_secs), [
            (Figure("fuzz lines/s, emulator paced to 115200 baud", "lines/s", ">= 500 (or wire >= 80 %)",
                    "higher", 500.0), "lines_per_s"),
            (Figure("115200-baud wire share, busier direction", "%", ">= 80 % (or >= 500 lines/s)", "higher",
                    80.0), "wire_share_pct")], None),
        ("report period", lambda: fidelity.report_period(seconds=secs), [
            (Figure("select report period error, mean", "ms", "< 1 ms", target=1.0), "mean_ms"),
            (Figure("select report period error, p99", "ms"), "p99_ms")], None),
        ("square wave period", fidelity.waveform_period, [
            (Figure("square wave period error, mean", "ms"), "mean_ms")], None),
        ("pulse done", lambda: fidelity.pulse_lateness(repeats=2 if quick else 3), [
            (Figure("pulse done lateness, mean", "ms"), "mean_ms"),
            (Figure("pulse done lateness, max", "ms"), "max_ms")], None),
        ("streaming cost", lambda: cost.streaming_cpu(seconds=secs), [
            (Figure("CPU share, 4 ports streaming at 10 ms", "% of a core"), "cpu_pct")], None),
        # Issue 13: a dead HAT must not cost the rest of the run; a flood must not grow the harness.
        ("dead target", lambda: target_faults.dead_target("silent"), [
            (Figure("time to declare a silent target dead (5 faults in a row)", "s", "<= 30 s", target=30.0),
             "declare_s")], 1),
        ("target that stops reading", lambda: target_faults.dead_target("deaf"), [
            (Figure("time to give up on a target that stops reading", "s", "<= 30 s", target=30.0),
             "declare_s")], 1),
        ("hung HAT reset", target_faults.hung_and_reset, [
            (Figure("time from a hung HAT to a passing case again (reset once)", "s"), "recover_s")], 1),
        ("flood memory", lambda: target_faults.flood_memory(20.0 if quick else target_faults.FLOOD_SECONDS), [
            (Figure("harness peak RSS, HAT flooding 3,000 lines/s", "MiB", "< 150 MB", target=143.0),
             "rss_mib"),
            (Figure("flooded lines kept in the transcript", "%", "100 %", "higher", 100.0), "kept_pct")], 1),
        ("memory", lambda: cost.memory_after_lines(lines), [
            (Figure(f"resident memory after {lines:,} lines", "MiB"), "rss_mib"),
            (Figure(f"memory growth over {lines:,} lines", "MiB"), "rss_growth_mib")], 1),  # deterministic
        # Issue 14: a host writing faster than the wire, through the user's `buildhat-emulator --pty --baud`.
        # write() returns early by what the link holds (a pty: 13-20 KB; docs/HOST-LIBRARIES.md); the
        # HAT's answer comes no sooner than the wire's time.
        ("host write at 115200 baud", host_write.host_write, [
            (Figure("host write() of 51,000 B, pty at --baud 115200", "s", "wire 4.43 s; UART ~4.07 s"),
             "write_s"),
            (Figure("bytes not yet on the wire when write() returned", "B", "UART <= 4,096"), "held_bytes"),
            (Figure("HAT's answer after the 51,000 B write", "s", ">= 4.43 s (the wire)", "higher", 4.43),
             "answer_s"),
            (Figure("version round trip at --baud 115200", "ms"), "version_rtt_ms")], None),
        # Issue 22: the real firmware built for this host (sil:), through the user's commands.
        ("suite on the firmware, virtual time", lambda: sil.suite(real_time=False, keyword=k), [
            (Figure("suite wall time against sil: (virtual time)", "s", "<= 20 s", target=20.0),
             "wall_s")], 2),
        ("suite on the firmware, real time", lambda: sil.suite(real_time=True, keyword=k), [
            (Figure("suite wall time against sil:?speed=1", "s"), "wall_s")], 1),
        ("fuzz on the firmware", lambda: sil.fuzz(seconds=fuzz_secs), [
            (Figure("fuzz lines/s against sil:", "lines/s", ">= 2,000", "higher", 2000.0), "lines_per_s"),
            (Figure("fuzz lines/s, sil: --against inprocess", "lines/s", ">= 2,000", "higher", 2000.0),
             "against_inprocess_lines_per_s"),
            (Figure("fuzz lines/s, sil: --against emulator", "lines/s", ">= 2,000", "higher", 2000.0),
             "against_emulator_lines_per_s"),
            (Figure("fuzz lines/s, sil: --against emulator --jobs 1", "lines/s"),
             "against_emulator_jobs1_lines_per_s")],
         None),
        ("firmware coverage", lambda: sil.coverage(fuzz_seconds=20.0 if quick else 60.0), [
            (Figure("firmware line coverage, whole suite", "%", ">= 90 %", "higher", 90.0), "suite_line_pct"),
            (Figure("firmware branch coverage, whole suite", "%"), "suite_branch_pct"),
            (Figure("firmware line coverage, one fuzz campaign", "%"), "fuzz_line_pct"),
            (Figure("firmware branch coverage, one fuzz campaign", "%"), "fuzz_branch_pct")], 1),
        # Issue 37: the emulator keeps the firmware's time (bench/same_world.py).
        ("emulator against the firmware, same world", same_world.measure, [
            (Figure("same world: lines equal", "%", "100 % but device noise", "higher"), "equal_pct"),
            (Figure("same world: equal lines within 1 ms", "%", "100 %", "higher", 100.0),
             "within_1ms_pct")], 1),
        ("mutation score", lambda: sil.mutation(count=8 if quick else 20), [
            (Figure("mutants killed by a failing case (not likely equivalent)", "%", ">= 95 %", "higher",
                    95.0), "score_pct"),
            (Figure("mutation campaign wall time", "s"), "seconds")], 1),
        ("firmware load", firmware_load.upload, [
            (Figure("upload of a 51 KB image (load, 115200 baud)", "s"), "upload_s"),
            (Figure("upload time above the wire's minimum", "%", "<= 5 %", target=5.0), "over_min_pct"),
            (Figure("whole load: bootloader to firmware running", "s"), "total_s")], None),
        # Issue 23: a labgrid lab on loopback (coordinator, exporter, ser2net; bench/lab.py).
        ("labgrid places", lab.place_costs, [
            (Figure("labgrid place: acquire + open (ser2net started)", "s"), "open_s"),
            (Figure("labgrid place: close + release", "s"), "close_s"),
            (Figure(f"suite -k {lab.KEYWORD} on one labgrid place", "s"), "one_s"),
            (Figure(f"suite -k {lab.KEYWORD} on two places at once", "s"), "two_s"),
            (Figure("two places at once / one place, wall time", "x", "~1.0 (in parallel)"), "ratio")], 1),
    ]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--runs", type=int, default=3, metavar="N",
                        help="repetitions per group (medians reported; default 3)")
    parser.add_argument("--quick", action="store_true", help="one run each, shorter measurements")
    # not -k: in `run` that is a pytest expression, here a plain piece of a group's name
    parser.add_argument("--group", dest="only", default="", metavar="TEXT",
                        help="only the groups whose name contains TEXT (e.g. fuzz)")
    add_hidden_alias(parser, "-k", dest="only")
    parser.add_argument("-o", "--output", default="reports/bench.json", metavar="FILE",
                        help="where to write the figures (default %(default)s)")
    parser.add_argument("--cprofile", metavar="DIR", default=None,
                        help="also run each group under cProfile and write its hottest functions to DIR")


def _loadavg() -> str:
    try:
        return " ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:
        return "?"


def _run(fn: Callable[[], dict], profile_to: Optional[str]) -> dict:
    if profile_to is None:
        return fn()
    import cProfile
    import io
    import pstats

    prof = cProfile.Profile()
    try:
        return prof.runcall(fn)
    finally:
        out = io.StringIO()
        stats = pstats.Stats(prof, stream=out)
        stats.sort_stats("tottime").print_stats(40)
        stats.sort_stats("cumulative").print_stats(40)
        os.makedirs(os.path.dirname(profile_to) or ".", exist_ok=True)
        with open(profile_to, "w", encoding="utf-8") as fh:
            fh.write(out.getvalue())


def main(args: argparse.Namespace) -> int:
    from ..plumbing.cli_options import UsageError, check_writable

    runs = 1 if args.quick else max(1, args.runs)
    profile_dir = getattr(args, "cprofile", None)
    names = [group[0] for group in _groups(args.quick)]
    if args.only and not any(args.only in name for name in names):
        raise UsageError(f"--group {args.only}: no benchmark group has it in its name ({'; '.join(names)})")
    check_writable(args.output, "-o")        # before the minutes of measuring, not after
    if profile_dir:
        check_writable(profile_dir, "--cprofile", folder=True)
    figures: List[Figure] = []
    loads: List[str] = [_loadavg()]
    began = time.monotonic()
    for group in _groups(args.quick):
        name, fn, wanted = group[0], group[1], group[2]
        cap = group[3] if len(group) > 3 else None
        if args.only and args.only not in name:
            continue
        n = min(runs, cap) if cap else runs
        print(f"measuring: {name} ({n} run{'s' if n > 1 else ''}) ...", end=" ", flush=True)
        group_began = time.monotonic()
        notes: List[str] = []
        for i in range(n):
            where = None if profile_dir is None else \
                os.path.join(profile_dir, f"{name.replace(' ', '-')}-{i}.txt")
            try:
                sample = _run(fn, where)
            except Exception as exc:  # a benchmark reports, it does not crash the table
                for fig, _key in wanted:
                    fig.note = f"{type(exc).__name__}: {exc}"[:160]
                break
            for fig, key in wanted:
                fig.samples.append(float(sample[key]))
            if sample.get("note"):
                notes.append(str(sample["note"]))
        if notes:
            for fig, _key in wanted:
                fig.note = fig.note or "; ".join(sorted(set(notes)))[:160]
        figures.extend(fig for fig, _key in wanted)
        loads.append(_loadavg())
        print(f"{time.monotonic() - group_began:.0f} s", flush=True)
    print()
    print(render_table(figures))
    meta = {"tool": f"buildhat-conformance {__version__}", "date": datetime.datetime.now().isoformat(),
            "machine": platform.platform(), "cpus": os.cpu_count(), "runs": runs,
            "python": platform.python_version(),
            # Shared machines are noisy: the load average before and after each group says how much.
            "loadavg": loads}
    write_json(figures, args.output, meta)
    print(f"\nload average (1, 5, 15 min) during the groups: {' | '.join(loads)}")
    print(f"measured in {time.monotonic() - began:.0f} s")
    print(f"written: {args.output}")
    return 0
