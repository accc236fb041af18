"""A fuzzing campaign: seeded runs under a budget, each finding confirmed, reduced and reported.

A run is a pure function of its seed: the prelude, then ``steps`` steps, each either a batch of
generated inputs sent back to back with one fence, or a wait. Nothing a target answers changes
what is drawn, so a run replays exactly, on any target. Run seeds derive from the campaign seed
(chosen at random when none is given, and printed), so a campaign with an example budget repeats.

A failed oracle is a candidate. It is confirmed by replaying the run's script ``confirm`` times
(fuzz/findings/replay.py); one that never fails again is listed as unconfirmed, not reported. A confirmed
one is reduced by replaying smaller scripts (fuzz/findings/shrink.py) and reported with how often it
reproduced (fuzz/findings/confirm.py), all within the campaign's bound on checking (fuzz/running/budget.py).
The
campaign goes on until the budget is spent; one finding per oracle is kept. A KeyboardInterrupt
(Ctrl-C, SIGTERM: fuzz/running/stop_signals.py) ends it at once, keeping a finding it cut short.

Targets that take seconds to start (a HAT, a process) stay open from run to run: the prelude
brings them back to a known state. In-process, every run starts on a freshly booted copy.
"""
from __future__ import annotations

import hashlib
import json
import os
import random
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Tuple, Union

from ...harness.targets.base import Target, TargetError
from ...protocol.profiles import Profile
from ...transcripts.script import Script
from ..findings.confirm import Check, CheckClock, Confirmed, check_finding
from ..findings.replay import replay_script
from ..inputs.generate import FAMILIES, InputGenerator
from ..inputs.grammar import grammar_for
from ..model.step_plan import output_groups
from ..oracles.registry import Finding, oracle_named
from ..oracles.setup_loss import for_target
from .budget import Budget, parse_budget
from .checked_run import Runner, Stats

__all__ = ["Budget", "parse_budget", "CampaignConfig", "CampaignResult", "Confirmed", "run_campaign",
           "run_seed", "new_seed", "not_done", "PRELUDE_REFUSALS"]

_GENERATOR_VERSION = 2      # part of the database key: a stored run seed means nothing to another generator
PRELUDE_REFUSALS = 3        # runs in a row the target may refuse to start before the campaign stops


def new_seed() -> int:
    return random.SystemRandom().randrange(1, 2**32)


def run_seed(seed: int, index: int) -> int:
    return int.from_bytes(hashlib.sha256(f"{seed}:{index}".encode()).digest()[:8], "big")


@dataclass
class CampaignConfig:
    open_primary: Callable[[], Target]
    profile: Profile
    open_secondary: Optional[Callable[[], Target]] = None
    secondary_profile: Optional[Profile] = None
    families: Tuple[str, ...] = FAMILIES
    steps: int = 40
    batch: int = 16               # at most this many inputs in one step
    waits: Tuple[int, ...] = (10, 60, 300)
    wait_share: float = 0.15      # the chance that a step is a wait
    fence_s: float = 2.0
    fresh: bool = True            # every open starts a freshly booted HAT (the layout is known)
    keep_open: bool = False       # one target for many runs (the prelude resets it)
    out_limit: Optional[int] = None   # bytes one exchange may print (a wire's TX ring)
    # output may meet a full TX ring (a wire, cmd:, sil:): fuzz/model/tx_ring.py; one flag, or one per side
    tx_ring: Union[bool, Tuple[bool, ...]] = False
    confirm: int = 3              # replays of a failing run; 0: reported as found, never replayed
    reduce_seconds: float = 30.0
    # checking findings, in all (fuzz/running/budget.py); None: no bound
    check_seconds: Optional[float] = None
    labels: Tuple[str, str] = ("target", "against")
    devices: Optional[Dict[int, Optional[tuple]]] = None   # the layout, when known
    stats: Stats = field(default_factory=Stats)


@dataclass
class CampaignResult:
    findings: List[Confirmed] = field(default_factory=list)
    unconfirmed: List[Tuple[Finding, int]] = field(default_factory=list)   # (finding, replays tried)
    elapsed: float = 0.0          # fuzzing time (confirming, reducing, starting targets not included)
    checking: float = 0.0         # time spent confirming and reducing
    cpu: float = 0.0              # this process's CPU time while fuzzing (a loaded machine shows here)
    runs: int = 0
    seed: int = 0
    interrupted: bool = False     # stopped by Ctrl-C (or SIGTERM) before the budget was spent
    check_limit: Optional[float] = None   # the bound on checking (--check-time), if any
    check_cut: int = 0            # findings whose checking that bound cut short
    prelude_failures: List[str] = field(default_factory=list)   # runs the target did not let start
    stopped: Optional[str] = None     # the target let no run start this many times in a row
    not_done: Optional[str] = None    # why the campaign could not do its job (exit 3), if it could not
    workers: int = 1              # campaigns run at once (--jobs); cpu is then their sum

    def finding(self, oracle: str) -> Optional[Confirmed]:
        return next((f for f in self.findings if f.oracle == oracle), None)


class _Keeper:
    """Targets kept open from run to run (``keep_open``); reopened after a failure."""

    def __init__(self, opener: Callable[[], Target], keep: bool):
        self.opener, self.keep = opener, keep
        self.target: Optional[Target] = None
        self.runs = 0             # runs since the last (re)open
        self.clean = False        # the last run on it ended without a finding

    @property
    def opens_new(self) -> bool:
        """The next call hands out a target no earlier run has used."""
        return not self.keep or self.target is None

    def __call__(self) -> Target:
        if not self.keep:
            return self.opener()
        if self.target is None:
            self.target = self.opener()
            self.runs = 0
            self.clean = False
        self.runs += 1
        return self.target

    def discard(self) -> None:
        if self.target is not None:
            try:
                self.target.close()
            except (TargetError, OSError):
                pass
        self.target = None


class Campaign:
    def __init__(self, config: CampaignConfig):
        self.config = config
        self.generator = InputGenerator(grammar_for(config.profile), config.families)
        self.keepers = [_Keeper(config.open_primary, config.keep_open)]
        self.against: Optional[Tuple[Callable[[], Target], Profile]] = None
        self.checking: Optional[Check] = None     # the finding being checked now, if any
        if config.open_secondary is not None:
            self.keepers.append(_Keeper(config.open_secondary, config.keep_open))
            self.against = (self.keepers[1], config.secondary_profile or config.profile)

    # -- one run ---------------------------------------------------------------------------------
    def _runner(self) -> Runner:
        c = self.config
        openers = [(c.labels[0], self.keepers[0], c.profile)]
        if self.against is not None:
            openers.append((c.labels[1], self.keepers[1], self.against[1]))
        # A target kept open knows its layout only for the first run after it booted: an earlier
        # run may have lost a device for good (a light matrix left without motor power stops
        # talking until replugged), and a model built from the layout would judge that port's
        # drive and reports as if the device were there (the sil `state` finding, issue 22). So
        # this is settled before the Runner builds its models, not after.
        fresh = c.fresh and all(k.opens_new for k in self.keepers)
        return Runner(openers, c.fence_s, fresh, c.stats, c.devices, keep_open=c.keep_open,
                      tx_ring=c.tx_ring)

    def run(self, seed: int, stop: Callable[[], bool] = lambda: False) -> None:
        """One run; raises the Finding of its first failed check. ``stop``: asked before each
        step; the run ends early when it says so (the budget is spent)."""
        c = self.config
        rng = random.Random(seed)
        settled = c.keep_open and all(k.clean for k in self.keepers)
        for k in self.keepers:
            k.clean = False
        t0 = time.monotonic()
        runner = self._runner()
        if c.keep_open and any(k.runs == 1 for k in self.keepers):
            # A target that takes seconds to start (a process booting, a HAT) was (re)started:
            # that is not fuzzing time; the summary reports it apart.
            c.stats.startup_s += time.monotonic() - t0
        runner.settled = settled
        try:
            runner.start()
            for _step in range(c.steps):
                if stop():
                    break
                if c.waits and rng.random() < c.wait_share:
                    runner.wait(rng.choice(c.waits))
                    continue
                batch = [self.generator.input(rng) for _ in range(rng.randint(1, c.batch))]
                datas = [inp.data for inp in batch]
                if c.out_limit is None:
                    groups = [datas]
                else:
                    groups, left_out = output_groups(runner.sides[0].model, datas, c.out_limit)
                    if left_out:
                        c.stats.left_out += len(left_out)
                        batch = [inp for i, inp in enumerate(batch) if i not in left_out]
                self._count(batch)
                for group in groups:
                    runner.exchange(group, guard=True)
                if runner.tainted:
                    # A line did what the facts leave open: the rest of this run could be judged
                    # on liveness alone. A new run (fresh, or after the prelude) judges fully.
                    break
                if c.stats.on_progress is not None:
                    c.stats.on_progress(c.stats)
            for k in self.keepers:
                k.clean = True
            if c.keep_open and c.fresh and self._set_up_in_part():
                # A HAT that took a device's set-up only in part lists it so until the device sets up
                # again, and that port is not compared meanwhile (setup_loss.py): new HATs compare it.
                self.discard_targets()
        finally:
            runner.close()

    def _set_up_in_part(self) -> bool:
        return self.against is not None and any(
            k.target is not None and for_target(k.target).ports() for k in self.keepers)

    def _count(self, batch) -> None:  # type: ignore[no-untyped-def]
        stats = self.config.stats
        for inp in batch:
            stats.executions += 1
            stats.lines += inp.data.count(b"\r")
            stats.productions.update(inp.productions)

    def discard_targets(self) -> None:
        for k in self.keepers:
            k.discard()
            k.clean = False           # the next run drains and syncs the new targets

    def after_failure(self, finding: Finding) -> None:
        """A target that stopped answering (or whose firmware crashed) is restarted; after any other
        failure it answered,
        and the next run's prelude (with a drain and a sync) brings it back to a known state:
        a restart would cost a kept-open target seconds per finding."""
        if oracle_named(finding.oracle).target_lost or not self.config.keep_open:
            self.discard_targets()

    # -- findings -------------------------------------------------------------------------------
    def replay(self, script: Script) -> Optional[Finding]:
        c = self.config
        fresh = c.fresh and not c.keep_open
        return replay_script(script, self.keepers[0], c.profile, c.fence_s, fresh=fresh, against=self.against,
                             keep_open=c.keep_open, on_fail=self.after_failure, tx_ring=c.tx_ring)

    def _note(self, text: str) -> None:
        if self.config.stats.on_note is not None:
            self.config.stats.on_note(text)

    def check(self, finding: Finding, seed: int, clock: CheckClock) -> Tuple[Check, Optional[Confirmed]]:
        """Confirm, reduce, confirm again, within the clock (fuzz/findings/confirm.py). The Check is made
        first, so an interrupt still finds it in ``self.checking`` (until it is kept)."""
        c = self.config
        self.after_failure(finding)
        check = self.checking = Check(finding, seed, c.devices if c.fresh else None)
        confirmed = check_finding(check, self.replay, c.confirm, c.reduce_seconds, clock.deadline(),
                                  clock.why() if clock.limit is not None else "", self._note)
        return check, confirmed


def not_done(result: CampaignResult, stats: Stats) -> Optional[str]:
    """Why a campaign did not do its job, in one line (None if it did): it sent no input, or
    the target answered none of it, or stopped answering so that the budget could not be used."""
    if result.interrupted:
        return None
    why = f" ({result.prelude_failures[0]})" if result.prelude_failures else ""
    if stats.executions == 0:
        if len(result.prelude_failures) >= result.runs:
            return f"no input was sent: none of {result.runs} run(s) got past the prelude{why}"
        return (f"no input was sent in {result.runs} run(s): the budget ran out before the first step, "
                "or every step drawn was a wait (give more --steps or a larger --budget)")
    if result.findings:
        return None
    if stats.answered == 0:
        first = f" (first: {result.unconfirmed[0][0].message})" if result.unconfirmed else why
        return (f"no input was accepted: {stats.executions} input(s) sent in {result.runs} run(s), and no "
                f"step's fence was answered{first}")
    if result.stopped:
        return f"the target stopped answering after {stats.answered} answered step(s): {result.stopped}"
    return None


def _database_key(config: CampaignConfig, scheme: str) -> str:
    parts = [str(_GENERATOR_VERSION), scheme, config.profile.name, ",".join(config.families),
             str(config.steps), str(config.batch), ",".join(map(str, config.waits)), f"{config.wait_share:g}"]
    return hashlib.sha256(":".join(parts).encode()).hexdigest()[:16]


def _stored_runs(folder: Optional[str]) -> List[int]:
    if folder is None or not os.path.isdir(folder):
        return []
    seeds = []
    for name in sorted(os.listdir(folder)):
        try:
            with open(os.path.join(folder, name), encoding="utf-8") as fh:
                seeds.append(int(json.load(fh)["run_seed"]))
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return seeds


def _store_run(folder: Optional[str], seed: int, oracle: str) -> None:
    if folder is None:
        return
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, f"{seed:016x}.json"), "w", encoding="utf-8") as fh:
        json.dump({"run_seed": seed, "oracle": oracle}, fh)


def _forget_run(folder: Optional[str], seed: int) -> None:
    if folder is not None:
        try:
            os.remove(os.path.join(folder, f"{seed:016x}.json"))
        except OSError:
            pass


def _keep(result: CampaignResult, check: Check, confirmed: Optional[Confirmed],
          folder: Optional[str]) -> None:
    """A checked finding reported (and its run stored for the next campaign), or listed as unconfirmed."""
    check.kept = True
    if confirmed is None:
        result.unconfirmed.append((check.finding, check.attempts))
    else:
        result.findings.append(confirmed)
        _store_run(folder, check.seed, check.finding.oracle)


def _checked(result: CampaignResult, stats: Stats, clock: CheckClock, since: Tuple[float, float]) -> float:
    """Counts the time since ``since`` as checking (not fuzzing); the CPU time it took."""
    took = time.monotonic() - since[0]
    result.checking += took
    clock.spent += took
    stats.checking_s = result.checking
    return time.process_time() - since[1]


def run_campaign(config: CampaignConfig, budget: Budget, seed: int, database: Optional[str] = None,
                 database_scheme: str = "", first: int = 0, stride: int = 1,
                 replay_stored: bool = True) -> CampaignResult:
    """Runs until the budget is spent. ``database``: a folder where failing runs are kept; the
    next campaign of the same kind replays them first (unless ``replay_stored`` is False).
    ``first``, ``stride``: the run indexes this campaign takes (``--jobs``: worker w of N takes
    w, w+N, ...; a run budget ``Kx`` is then the runs of indexes below K), so every run is the one
    a single campaign of that seed would draw at that index."""
    campaign = Campaign(config)
    result = CampaignResult(seed=seed)
    folder = os.path.join(database, _database_key(config, database_scheme)) if database else None
    stored = _stored_runs(folder) if replay_stored else []
    if budget.examples is not None and stride > 1:
        budget = Budget(examples=len(range(first, budget.examples, stride)))
    start = time.monotonic()
    cpu_start, checking_cpu = time.process_time(), 0.0
    index, refused = first, 0
    clock = CheckClock(config.check_seconds)
    result.check_limit = config.check_seconds
    since: Optional[Tuple[float, float]] = None      # (wall, CPU) time the check under way began

    def spent() -> bool:
        return budget.seconds is not None and time.monotonic() - start - result.checking \
            - config.stats.startup_s >= budget.seconds

    try:
        while True:
            if spent():
                break
            if budget.examples is not None and result.runs >= budget.examples and not stored:
                break
            from_store = bool(stored)
            seed_i = stored.pop(0) if stored else run_seed(seed, index)
            index += 0 if from_store else stride
            result.runs += 1
            config.stats.examples = result.runs
            try:
                campaign.run(seed_i, spent)
                refused = 0
                if from_store:
                    _forget_run(folder, seed_i)      # it passes now
                continue
            except Finding as exc:
                finding = exc
            if finding.details.get("prelude"):
                # The target did not take the prelude: no fuzzed input was judged, so this is not a
                # finding; a target that keeps refusing ends the campaign (it cannot use its budget).
                result.prelude_failures.append(finding.message)
                campaign.after_failure(finding)
                refused += 1
                if refused >= PRELUDE_REFUSALS:
                    result.stopped = f"{refused} runs in a row could not start: {finding.message}"
                    break
                continue
            refused = 0
            since = (time.monotonic(), time.process_time())
            known = result.finding(finding.oracle)
            if known is not None:
                known.also_seen += 1
                campaign.after_failure(finding)
            else:
                check, confirmed = campaign.check(finding, seed_i, clock)
                result.check_cut += check.clock_cut
                _keep(result, check, confirmed, folder)
                campaign.checking = None
            checking_cpu += _checked(result, config.stats, clock, since)
            since = None
    except KeyboardInterrupt:
        result.interrupted = True    # what ran so far is still summarised and written
        check = campaign.checking
        if check is not None and not check.kept:    # a finding cut short while it was being checked
            _keep(result, check, check.result(check.interrupted()), folder)
    finally:
        if since is not None:
            checking_cpu += _checked(result, config.stats, clock, since)
        campaign.discard_targets()
    result.elapsed = time.monotonic() - start - result.checking - config.stats.startup_s
    result.cpu = time.process_time() - cpu_start - checking_cpu
    result.not_done = not_done(result, config.stats)
    return result
