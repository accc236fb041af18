"""Checking a finding: replaying its run ``--confirm`` times, reducing it (fuzz/findings/shrink.py) and
confirming the reduced script, all within the time the campaign has left for checking.

The progress of a check is kept as it goes (:class:`Check`), so a check the clock or Ctrl-C cuts
short still gives what it had: the failing run (its script and every byte of its transcripts),
the replays done so far, the smallest failing script found so far; the finding says what was
cut short. A finding whose replays all passed is not reported (it stays an unconfirmed failure).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Tuple

from ...transcripts.script import Script
from ..oracles.registry import Finding
from .finding_scripts import script_from_trace
from .shrink import reduce_finding

__all__ = ["Confirmed", "Check", "CheckClock", "check_finding", "same_failure"]

Replay = Callable[[Script], Optional[Finding]]


@dataclass
class Confirmed:
    """A reported finding: the (reduced) failure, its script and how often replays failed.
    ``cut``: what of its checking did not happen, and why (None: confirmed and reduced)."""

    finding: Finding
    script: Script
    reproduced: int
    attempts: int
    run_seed: int
    also_seen: int = 0
    cut: Optional[str] = None

    @property
    def oracle(self) -> str:
        return self.finding.oracle


def same_failure(finding: Optional[Finding], oracle: str) -> bool:
    """A replay failed ``oracle`` again (a replay the target did not let start proves nothing)."""
    return finding is not None and finding.oracle == oracle and not finding.details.get("prelude")


class CheckClock:
    """The time a campaign may spend checking findings, in all (``--check-time``; None: no bound
    beyond each finding's own). ``cut`` counts the findings whose checking it cut short."""

    def __init__(self, limit: Optional[float]):
        self.limit = limit
        self.spent = 0.0
        self.cut = 0

    def deadline(self) -> float:
        """The monotonic time the check starting now must end by."""
        return float("inf") if self.limit is None else time.monotonic() + max(0.0, self.limit - self.spent)

    def why(self) -> str:
        return f"the checking time (--check-time {self.limit:g}s) ran out"


@dataclass
class Check:
    """How far the checking of one finding got."""

    finding: Finding
    seed: int
    devices: Optional[Dict[int, Optional[tuple]]] = None
    hits: int = 0
    attempts: int = 0
    smaller: Optional[Tuple[Script, Finding]] = None     # the smallest failing script found so far
    clock_cut: bool = False       # the check clock cut some of it short
    kept: bool = False            # its result is in the campaign's (an interrupt must not keep it twice)

    def __post_init__(self) -> None:
        self.script = script_from_trace(self.finding, self.devices)

    def interrupted(self) -> str:
        """What an interrupt (Ctrl-C, SIGTERM) cut short."""
        if not self.attempts:
            return "not confirmed: interrupted before its first replay"
        if self.smaller is None:
            return (f"interrupted while it was being checked ({self.hits} of {self.attempts} replays "
                    "failed again)")
        return "interrupted while it was being reduced: the smallest failing script found so far"

    def result(self, cut: Optional[str]) -> Optional[Confirmed]:
        """What the check has shown so far (None: replays ran and none failed again)."""
        if self.attempts and not self.hits:
            return None
        if self.smaller is not None:
            # Reduction keeps a smaller script only when its replay failed the same way: once, at least.
            script, finding = self.smaller
            return Confirmed(finding, script, 1, 1, self.seed, cut=cut)
        return Confirmed(self.finding, self.script, self.hits, self.attempts, self.seed, cut=cut)


def _replays(script: Script, oracle: str, replay: Replay, times: int, deadline: float) -> Tuple[int, int]:
    """(failed again, replays run): up to ``times`` replays, none started after ``deadline``."""
    hits = attempts = 0
    while attempts < times and time.monotonic() < deadline:
        hits += same_failure(replay(script), oracle)
        attempts += 1
    return hits, attempts


class _Cuts:
    """What of a check did not happen: the clock's cuts (its reason said once) and the others."""

    def __init__(self, check: Check, clock_why: str):
        self.check, self.clock_why = check, clock_why
        self.clock: List[str] = []
        self.other: List[str] = []

    def by_clock(self, what: str) -> None:
        self.check.clock_cut = True
        self.clock.append(what)

    def text(self) -> Optional[str]:
        parts = self.other + ([f"{', '.join(self.clock)}: {self.clock_why}"] if self.clock else [])
        return "; ".join(parts) or None


def check_finding(check: Check, replay: Replay, confirm: int, reduce_seconds: float, deadline: float,
                  clock_why: str, note: Callable[[str], None]) -> Optional[Confirmed]:
    """Confirm ``check.finding`` (``confirm`` replays), reduce it, confirm the reduced script; none
    of it started past ``deadline`` (``clock_why`` says why, and ``check.clock_cut`` is set).
    ``check`` keeps the progress, so a KeyboardInterrupt leaves it readable. None when no
    replay failed the same way."""
    oracle = check.finding.oracle
    if confirm == 0:
        return check.result("not replayed (--confirm 0): neither confirmed nor reduced")
    note(f"a [{oracle}] failure: replaying it {confirm} time(s) to confirm it")
    while check.attempts < confirm and time.monotonic() < deadline:
        check.hits += same_failure(replay(check.script), oracle)
        check.attempts += 1
    cuts = _Cuts(check, clock_why)
    if check.attempts < confirm:
        cuts.by_clock(f"{check.attempts} of {confirm} replays ran" if check.attempts else
                      "not confirmed: no replay ran")
        if not check.attempts:
            return check.result(cuts.text())
    if not check.hits:
        note(f"the [{oracle}] failure did not happen again: not reported")
        return None
    limit = min(reduce_seconds, deadline - time.monotonic())
    if limit <= 0:
        if reduce_seconds > 0:
            cuts.by_clock("not reduced")
        return check.result(cuts.text())
    note(f"[{oracle}] reproduced {check.hits}/{check.attempts}; reducing it by replaying smaller scripts "
         f"(at most {limit:.1f} s)")

    def smaller(script: Script, finding: Finding) -> None:
        check.smaller = (script, finding)

    reduced, found = reduce_finding(check.script, check.finding, replay, limit, on_smaller=smaller)
    if limit < reduce_seconds and time.monotonic() >= deadline:
        cuts.by_clock("its reduction cut short")
    if found is check.finding:
        return Confirmed(check.finding, check.script, check.hits, check.attempts, check.seed, cut=cuts.text())
    hits, attempts = _replays(reduced, oracle, replay, confirm, deadline)
    if not attempts:
        # The reduced script failed once, in the reduction; no time was left to replay it again.
        cuts.by_clock("the reduced script replayed only once, in its reduction")
        return Confirmed(found, reduced, 1, 1, check.seed, cut=cuts.text())
    if attempts < confirm:
        cuts.by_clock(f"the reduced script replayed {attempts} of {confirm} times")
    if hits:
        return Confirmed(found, reduced, hits, attempts, check.seed, cut=cuts.text())
    cuts.other.append("not reduced: the smaller script did not fail again")
    return Confirmed(check.finding, check.script, check.hits, check.attempts, check.seed, cut=cuts.text())
