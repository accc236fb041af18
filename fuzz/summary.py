"""What ``buildhat-conformance fuzz`` prints: the progress line and notes while it runs (on
stderr; a note repeated word for word is printed once and counted), and the closing summary
(on stdout): figures, coverage, checks, findings, and what kept the campaign from its job.
"""
from __future__ import annotations

import sys
import time
from collections import Counter
from typing import Dict, Hashable, Iterable, List, Optional, Tuple, TypeVar

from .running.campaign import Budget, CampaignResult
from .running.checked_run import Stats
from .running.target_exchange import WIRE_BYTES_PER_S

__all__ = ["Progress", "print_summary", "collapsed", "KEPT_OPEN"]

# A finding whose run began on a target that earlier runs left (kept open) says so.
KEPT_OPEN = "a target earlier runs had left open; a freshly started one may not reproduce it"


_T = TypeVar("_T", bound=Hashable)


def collapsed(texts: Iterable[_T]) -> List[Tuple[_T, int]]:
    """Each distinct text once, in first-seen order, with how often it came."""
    return list(Counter(texts).items())


def _times(n: int) -> str:
    return f" (x{n})" if n > 1 else ""


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
        self.notes: Counter = Counter()

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
        """A plain line (on a terminal, below the progress line); a repeat is only counted
        (the end says how often each came)."""
        self.notes[text] += 1
        if self.enabled and self.notes[text] == 1:
            self.stream.write(("\n" if self.tty else "") + f"[fuzz] {text}\n")
            self.stream.flush()

    def end(self, stats: Stats) -> None:
        if self.enabled and self.tty:
            self.stream.write("\r" + self.line(stats) + "\n")
        if self.enabled:
            for text, n in self.notes.items():
                if n > 1:
                    self.stream.write(f"[fuzz] {n} times in all: {text}\n")
        self.stream.flush()


def _findings(result: CampaignResult, files: Dict[str, Dict[str, str]]) -> None:
    if not result.findings:
        print("  no findings")
    for f in result.findings:
        again = f", seen {f.also_seen} more time(s)" if f.also_seen else ""
        replays = f"reproduced {f.reproduced}/{f.attempts}" if f.attempts else "not replayed"
        print(f"  FINDING [{f.oracle}] ({replays}{again}): {f.finding.message}")
        if f.cut:
            print(f"      checking cut short: {f.cut}")
        if not f.finding.details.get("fresh", True):
            print(f"      began on {KEPT_OPEN}")
        for what, path in files.get(f.oracle, {}).items():
            print(f"      {what}: {path}")
    tries: Dict[Tuple[str, str], int] = {}
    for finding, n in result.unconfirmed:
        tries.setdefault((finding.oracle, finding.message), n)
    for (oracle, message), n in collapsed((f.oracle, f.message) for f, _n in result.unconfirmed):
        print(f"  unconfirmed [{oracle}]{_times(n)} (0/{tries[(oracle, message)]} replays failed again; "
              f"not reported): {message}")
    for reason, n in collapsed(result.prelude_failures):
        print(f"  {n} run(s) could not start (the prelude was not answered; not a finding): {reason}")


def _check_bound(result: CampaignResult) -> str:
    """The bound on checking, when it cut a finding's checking short (the summary line says so)."""
    if not result.check_cut or result.check_limit is None:
        return ""
    return (f", cut short at its bound, --check-time {result.check_limit:g}s: {result.check_cut} finding(s) "
            "not fully checked")


def print_summary(result: CampaignResult, stats: Stats, productions, files: Dict[str, Dict[str, str]],  # type: ignore[no-untyped-def]
                  junit: str, seed: int, chosen: bool, wire: bool, out_limit: Optional[int]) -> None:
    """The closing summary. ``wire``: the target is a paced or real 115200-baud wire (only then
    is a share of that wire worth printing)."""
    el = max(result.elapsed, 1e-9)
    apart = ([f"{result.checking:.1f} s confirming findings{_check_bound(result)}"]
             if result.checking >= 0.05 or result.check_cut else []) + \
        ([f"{stats.startup_s:.1f} s starting targets"] if stats.startup_s >= 0.05 else [])
    checking = f" (and {', '.join(apart)})" if apart else ""
    print(f"fuzz: {result.runs} runs, {stats.executions} inputs ({stats.lines} lines, "
          f"{stats.lines / el:.0f} lines/s) in {result.elapsed:.1f} s{checking}")
    if result.cpu > 0:
        # On a shared machine the wall-clock rate is what others leave over; this is the fuzzer's own.
        who = f"{result.workers} workers" if result.workers > 1 else "this process"
        print(f"  {who}: {result.cpu:.1f} s of CPU, "
              f"{stats.lines / result.cpu:.0f} lines per CPU second")
    if wire:
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
    if stats.ring_lossy:
        print(f"  {stats.ring_lossy} step(s) lost output to a full TX ring while output streamed "
              "(allowed: docs/FIRMWARE-BEHAVIOUR.md#fb-tx-ring); judged on what a full ring leaves")
    if stats.ring_unjudged:
        print(f"  {stats.ring_unjudged} step(s) may have lost output to a full TX ring on one side where the "
              "facts do not settle what the step prints (so no model could judge the loss): the sides "
              "compared only up to the bytes the ring always keeps")
    if stats.matrix_apart:
        print(f"  {stats.matrix_apart} time(s) one side's light matrix stopped talking and the other's "
              "not (its 1 s without motor power ends at other instants on each side's clock): its "
              "`list` block not compared from then on")
    if stats.reconnect_apart:
        print(f"  {stats.reconnect_apart} step(s) listed a port one side was still setting up again (set-up "
              "times are a model difference, and each side's clock has its own instants): that port's "
              "`list` block not compared in them")
    if stats.setup_loss_apart:
        print(f"  {stats.setup_loss_apart} step(s) listed a port whose set-up one side took only in part "
              "(`MQ overrun!` while it set up: the messages lost depend on each side's timing): that port's "
              "`list` block not compared until it sets up again")
    if stats.left_out and out_limit is not None:
        print(f"  {stats.left_out} input(s) not sent: the answer of each alone is over {out_limit} bytes, "
              f"more than the TX ring keeps on this wire")
    _findings(result, files)
    print(f"  junit: {junit}")
    if result.interrupted:
        print("  interrupted (Ctrl-C or SIGTERM): the figures and findings above cover what ran; a finding "
              "whose checking was cut short says so")

