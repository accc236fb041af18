"""One checked run: open the target(s), bring them to a known state, then exchange input and
check every oracle after each step. Used by the campaign (fuzz/running/campaign.py) and by the
replay of a finding's script (fuzz/findings/replay.py), so a replay judges exactly as the fuzzer did.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable, Dict, FrozenSet, List, NoReturn, Optional, Sequence, Set, Tuple, Union

from ...harness.events import classify, line_kind
from ...harness.targets.base import Target, TargetError
from ...protocol.profiles import Profile
from ..findings.explain import differential_message, liveness_message, stream_message
from ..model.expect import LineFate
from ..model.port_model import UNKNOWN_Q16, mode_count
from ..model.reference_model import ReferenceModel
from ..model.step_plan import plan_step
from ..model.tx_ring import UNHELD_DEBUG, WIRE_BYTES_PER_MS, backlog, drain_ms, headroom, input_ms
from ..oracles.built_in import CRASH, DIFFERENTIAL, FATE, LIVENESS, SANITIZER
from ..oracles.differential import (
    first_difference,
    open_dump,
    parted_matrix,
    sync_bytes_before,
    synchronous_part,
)
from ..oracles.lossy_match import match_lossy
from ..oracles.reconnecting import for_target as reconnecting_on
from ..oracles.registry import Answer, Problem, oracle_named, oracles
from ..oracles.setup_loss import for_target
from ..oracles.state_check import check_drive, expect_reports, follow_links, observe
from ..oracles.stream_match import allowed_kinds, match_stream, without_torn
from .target_exchange import FENCE, ExchangeTimeout, TargetExchange

__all__ = ["Runner", "Side", "Stats", "PRELUDE"]

# Puts any HAT into a state the model knows: echo and debug off, no selection, port 0.
PRELUDE = b"echo 0\rdebug 0\rport 3\rselect\rport 2\rselect\rport 1\rselect\rport 0\rselect\r"
# On a HAT earlier runs left open the layout is not taken for granted (a device may have gone, or
# come): the prelude ends with `list`, and its answer says which active devices are there.
LIST = b"list\r"
LIST_ANSWER_MAX = 6000      # four ports' blocks (a motor's about 1 KB): the prelude's deadline allows it


@dataclass
class Stats:
    """Campaign figures, shared by every run."""

    examples: int = 0
    executions: int = 0           # inputs sent
    lines: int = 0                # CR-terminated lines sent (fences excluded)
    productions: Set[str] = field(default_factory=set)
    responses: Set[str] = field(default_factory=set)
    checks: Dict[str, int] = field(default_factory=dict)
    sent_bytes: int = 0           # over the first target's wire, fences included
    recv_bytes: int = 0
    left_out: int = 0             # inputs not sent: their answer alone would overflow the TX ring
    startup_s: float = 0.0        # time spent starting kept-open targets (not fuzzing)
    checking_s: float = 0.0       # time spent confirming and reducing findings (not fuzzing)
    liveness_only: int = 0        # steps judged on liveness alone (a raw serial trace on a timed link)
    answered: int = 0             # steps whose fence the (first) target answered: input it took
    ring_lossy: int = 0           # steps that lost output to a full TX ring, as the facts allow
    matrix_apart: int = 0         # runs whose sides parted on a light matrix (differential.parted_matrix)
    reconnect_apart: int = 0      # steps that left out a port one side was setting up again (reconnecting.py)
    setup_loss_apart: int = 0     # steps that left out a port a side set up only in part (setup_loss.py)
    ring_unjudged: int = 0        # steps a ring may have cut unjudged by a model: compared up to the cut
    on_progress: Optional[Callable[[Stats], None]] = None
    on_note: Optional[Callable[[str], None]] = None     # what the campaign is doing besides fuzzing

    def count(self, oracle: str, n: int = 1) -> None:
        self.checks[oracle] = self.checks.get(oracle, 0) + n


def _identity_lines(sides: Sequence[Side]) -> FrozenSet[bytes]:
    """When the sides are different builds (their `version` lines differ: a build no profile knows
    against the emulator of the nearest release), the lines that only say which build each is: the
    sides' help texts (each side's own, fuzz/running/release.py). Each side's own model judges them; the
    differential oracle leaves them (and `version` and `signature` lines) out. Empty otherwise."""
    if len(sides) < 2 or len({side.fence_line for side in sides}) == 1:
        return frozenset()
    return frozenset(line.encode("utf-8") for side in sides for line in side.profile.help_lines if line) \
        | {b"Firmware version:"}


class Side:
    """One target, its link and the model of its state."""

    def __init__(self, label: str, target: Target, profile: Profile, fence_s: float):
        self.label, self.profile = label, profile
        self.link = TargetExchange(target, label, fence_s)
        self.model = ReferenceModel(profile)
        self.fence_line = f"Firmware version: {profile.version_string}\r\n".encode()
        self._allowed: Dict[Optional[int], frozenset] = {}

    def allowed(self, debug: Optional[int]) -> frozenset:
        """:func:`allowed_kinds` for this side's release, kept per debug value (asked for every
        input; the profile never changes)."""
        kinds = self._allowed.get(debug)
        if kinds is None:
            if len(self._allowed) >= 64:      # fuzzed debug values: keep the table small
                self._allowed.clear()
            kinds = self._allowed[debug] = allowed_kinds(self.profile, debug)
        return kinds

    def close(self) -> None:
        try:
            self.link.target.close()
        except (TargetError, OSError):   # closing a broken target must not hide the finding
            pass


# The response classes seen are coverage figures, not judgements: a line's kind is looked up once
# per shape (the line without digits, signs, points and spaces), as data lines differ only in
# their numbers (profile: classifying every line was a tenth of an in-process campaign).
_KINDS: Dict[bytes, str] = {}
_NUMBERS = b"0123456789+-. "


def _kinds_of(out: bytes) -> Set[str]:
    kinds = set()
    for line in set(out.split(b"\r\n")[:-1]):
        if line[2:3] == b">" and line[:1] == b"P":
            kinds.add("unknown")      # a prompt, then echo: never a response class
            continue
        shape = line.translate(None, _NUMBERS)
        kind = _KINDS.get(shape)
        if kind is None:
            if len(_KINDS) >= 65536:          # noise lines: keep the table bounded
                _KINDS.clear()
            kind = _KINDS[shape] = line_kind(line)
        kinds.add(kind)
    return kinds


def _after_fence(out: bytes, fence_line: bytes) -> bytes:
    """What came after the last fence's answer (not compared: no command printed it), or b""."""
    at = out.rfind(fence_line)
    return out[at + len(fence_line):] if at >= 0 else b""


class Runner:
    """The sides of one run and the checks made after each step (raise a Finding on failure)."""

    def __init__(self, openers: Sequence[Tuple[str, Callable[[], Target], Profile]], fence_s: float = 2.0,
                 fresh: bool = True, stats: Optional[Stats] = None,
                 devices: Optional[Dict[int, Optional[tuple]]] = None, keep_open: bool = False,
                 tx_ring: Union[bool, Sequence[bool]] = False):
        """``openers`` may hand out targets that are already open (a campaign reusing one
        target for many runs); ``keep_open``: :meth:`close` leaves them open. ``tx_ring``: the
        targets' output may wait in a TX ring that drops it when full (a paced or real wire, a
        `cmd:` target, the firmware in the loop: fuzz/model/tx_ring.py); one flag for every side, or
        one per side (``--against``: our unpaced emulator has no ring to wait for)."""
        self.stats = stats or Stats()
        # The oracles judging every answer (counted in this order: by priority), added ones included.
        self._per_answer = sorted((o for o in oracles() if o.per_answer), key=lambda o: o.priority)
        self._checks = [o.check for o in self._per_answer if o.check is not None]
        self.sides: List[Side] = []
        self.kinds_seen: Set[str] = set()
        self.fresh = fresh
        self.keep_open = keep_open
        self.settled = False      # the targets come from a run that ended cleanly (see start)
        self.rings = ([bool(tx_ring)] * len(openers) if isinstance(tx_ring, bool)
                      else [bool(r) for r in tx_ring])
        if len(self.rings) != len(openers):
            raise ValueError(f"tx_ring: {len(self.rings)} flag(s) for {len(openers)} side(s)")
        self.tx_ring = any(self.rings)     # the inputs: every side receives the same bytes
        self._queued: List[int] = []   # per side: what streams may have queued in the TX ring
        self._apart: Set[int] = set()  # ports whose light matrix one side lost (not compared)
        # per side: the connect dump the last read ended inside of (differential.open_dump)
        self._dump_open: List[bytes] = []
        for label, opener, profile in openers:
            try:
                target = opener()
            except TargetError as exc:
                self.fail(LIVENESS.name, f"{label}: the target could not be opened: {exc}", {"prelude": True})
            side = Side(label, target, profile, fence_s)
            if devices is not None and fresh:
                # The layout the target booted with (known only for targets started fresh).
                side.model = ReferenceModel(profile, devices)
            self.sides.append(side)
            self._queued.append(0)
            self._dump_open.append(b"")
            if target.is_open:
                continue
            try:
                target.open()
            except TargetError as exc:
                self.fail(LIVENESS.name, f"{label}: the target could not be opened: {exc}", {"prelude": True})

    @cached_property
    def _identity(self) -> FrozenSet[bytes]:
        """What the differential oracle leaves out as naming each side's build (:func:`_identity_lines`)."""
        return _identity_lines(self.sides)

    def start(self, prelude: bytes = PRELUDE) -> None:
        """Drain the start-up output and send the prelude (not judged: the state before it is unknown).
        A target that a clean run just left (``settled``) answers at once: no drain, no sync; what
        is still on its way ends up in the prelude's answer."""
        if not self.fresh and not prelude.endswith(LIST):     # (a replayed script's has it)
            prelude += LIST
        listing = LIST_ANSWER_MAX if prelude.endswith(LIST) else 0
        for side in self.sides:
            try:
                drained = b""
                if not self.settled:
                    drained = side.link.drain()
                    side.link.sync(side.fence_line)
                out = drained + side.link.exchange(prelude, side.fence_line, 1, listing)
            except ExchangeTimeout as exc:
                self.firmware_reports(side, prelude, exc.received)    # it crashed: that is a finding
                # Not a finding: no fuzzed input was sent yet (the campaign counts these apart).
                self.fail(LIVENESS.name, f"{side.label}: no answer after the prelude: {exc}",
                          {"step": prelude, "received": exc.received, "prelude": True})
            self.firmware_reports(side, prelude, out)
            self._track(side, out)      # (what an earlier run's set-up printed may arrive here)
            self._dump_open[self.sides.index(side)] = open_dump(_after_fence(out, side.fence_line))
            side.model.feed(prelude)
            side.model.feed(FENCE)
            if not self.fresh:
                # An earlier run left this HAT: the prelude resets the selections, not the combi
                # tables (a report may come as C<m> where this run set no combi), nor the drive
                # settings (mode, bias, pwmparams, plimit: the duty is judged once this run set them).
                for p in side.model.ports:
                    p.known = False
                    p.forget_combis()
                    p.forget_drive(side.profile.commands)
                side.model.plimit = UNKNOWN_Q16
                self._listed_devices(side, out[:max(0, out.rfind(side.fence_line))])

    def _listed_devices(self, side: Side, answer: bytes) -> None:
        """The active devices the prelude's `list` names, on ports not being set up again (whose
        lines are the set-up's, not a device's that is there): the drive and report checks
        (statecheck.py) judge them from this run's first step, as on a fresh HAT."""
        setting_up = reconnecting_on(side.link.target).ports(side.link.target_now)
        for raw in answer.split(b"\r\n"):
            ev = classify(raw)
            port, ident = ev.port, ev.fields.get("id")
            if ev.kind != "list_port" or port is None or not 0 <= port <= 3 or port in setting_up:
                continue
            active = ev.fields.get("state") == "active"
            modes = mode_count(ident) if active and isinstance(ident, int) else 0
            side.model.ports[port].device_modes = modes

    @property
    def tainted(self) -> bool:
        """A side's model lost track of the state (model.UNSPECIFIED): only liveness is judged."""
        return any(side.model.tainted for side in self.sides)

    def close(self) -> None:
        link = self.sides[0].link if self.sides else None
        if link is not None:
            self.stats.sent_bytes += link.sent_bytes
            self.stats.recv_bytes += link.recv_bytes
        if not self.keep_open:
            for side in self.sides:
                side.close()

    # -- steps ---------------------------------------------------------------------------------
    def _send(self, side: Side, data: bytes, blob: bytes) -> None:
        try:
            side.link.send(data)
        except TargetError as exc:
            self.firmware_reports(side, blob, b"")
            self.fail(LIVENESS.name, f"{side.label}: the target went away: {exc}",
                      {"step": blob, "received": b""})

    def exchange(self, datas: Sequence[bytes], guard: bool = False,
                 pause_ms: Optional[int] = None) -> List[bytes]:
        """One step: the inputs back to back and one fence, written to every side before any
        answer is read; then each answer is checked. With ``guard``, inputs that would leave
        debug bit 1 set (with ``tx_ring``, also 8 or 16) get :data:`DEBUG_OFF` (decided on the first
        side's model, so every side receives the same bytes). A step whose output may meet a
        full TX ring lets it drain before the fence (``pause_ms``: that many HAT ms, as a
        replayed script says; None: as fuzz/model/tx_ring.py reckons); only a side with a ring pauses:
        one without (our emulator unpaced) has nothing to drain, and on a wall-clock target the
        pause would idle the campaign. Returns each side's answer."""
        # A port set up again is left out of the comparison if it was at any time in the step: its
        # `established` may come in the same answer as a `list` printed before it (reconnecting.py).
        settling = self._settling() if len(self.sides) == 2 else frozenset()
        # Where a ring applies, the debug streams it does not hold back are guarded too
        # (fuzz/model/tx_ring.py).
        mask = (1 | UNHELD_DEBUG if self.tx_ring else 1) if guard else 0
        before = [side.model.debug for side in self.sides]
        first = plan_step(self.sides[0].model, datas, mask)
        plans = [first] + [plan_step(side.model, first.datas) for side in self.sides[1:]]
        queued = [backlog(p.states, d | side.model.debug, side.model.selrate_engine,
                          bool(side.profile.feature("tx_throttle_reports"))) if ring else 0
                  for side, p, d, ring in zip(self.sides, plans, before, self.rings)]
        # What a stream stopped by the last step queued may still be draining ahead of this answer.
        queued, self._queued = [max(q, last) for q, last in zip(queued, self._queued)], queued
        keeps = [headroom(q, p.size_max) if ring else None for p, q, ring in zip(plans, queued, self.rings)]
        # A reckoned pause ends early where the target tells its command port is at rest (the
        # firmware in the loop: the step's output has left the ring), once the input has arrived;
        # a replayed script's pause is waited in full.
        settle = pause_ms is None
        if pause_ms is None:
            pause_ms = max([drain_ms(p.size_max, len(p.blob), k)
                            for p, k in zip(plans, keeps) if k is not None], default=0)
        pauses = [pause_ms if ring else 0 for ring in self.rings]
        records = []
        for side, plan, pause in zip(self.sides, plans, pauses):
            records.append(len(getattr(side.link.target, "line_records", ())))
            self._send(side, plan.blob[:-len(FENCE)] if pause else plan.blob, plan.blob)
        early = [(side.link.settle(input_ms(len(plan.blob)), pause) if settle else side.link.wait(pause))
                 if pause else b"" for side, plan, pause in zip(self.sides, plans, pauses)]
        for side, plan, pause in zip(self.sides, plans, pauses):
            if pause:
                self._send(side, FENCE, plan.blob)
        lost = False
        # Per side, the bytes of the step's output that fit in its ring, where a full ring may have
        # dropped the rest and the model could not judge it (the facts leave the step unsettled):
        # the differential oracle then compares up to there only.
        unjudged: List[Optional[int]] = [None] * len(self.sides)
        leading = list(self._dump_open)      # a dump's first lines, read with the last answer
        answers: List[bytes] = []
        compared: List[bytes] = []       # what the differential oracle compares (echo made whole)
        for side, plan, before, keep, ahead, queue, pause in zip(self.sides, plans, records, keeps, early,
                                                                 queued, pauses):
            self.stats.count(LIVENESS.name)
            try:
                # (fence lines that came during the pause count: a `version` among the inputs; the
                # answer may wait behind what streams in the TX ring)
                # A `version` among the inputs may lose its answer to a full ring: then the last
                # fence's, sent after the pause, is enough.
                got = ahead + side.link.receive(side.fence_line, plan.fences - ahead.count(side.fence_line),
                                                plan.size + queue, len(plan.blob),
                                                prompt=None if side.model.tainted else bool(side.model.echo),
                                                at_least=1 if keep is not None and pause else None)
            except ExchangeTimeout as exc:
                self.firmware_reports(side, plan.blob, ahead + exc.received)
                message, more = liveness_message(side.label, str(exc), plan.blob, side.fence_line,
                                                 ahead + exc.received)
                self.fail(LIVENESS.name, message, dict(more, step=plan.blob, received=ahead + exc.received))
            self.firmware_reports(side, plan.blob, got)
            if side is self.sides[0]:
                self.stats.answered += 1
            answers.append(got)
            compared.append(got)
            self._track(side, got)
            self._dump_open[len(answers) - 1] = open_dump(_after_fence(got, side.fence_line))
            self._note_kinds(got)
            if plan.debug & 1 and side.link.timed:
                # The raw serial trace (debug bit 1, fb-debug) has no line structure; where input
                # takes time to arrive it runs until the guard's `debug 0` is read. Liveness only.
                if not side.model.tainted:
                    follow_links(side.model, got, plan.states)
                    side.model.ports[:] = plan.states[-1]
                self.stats.liveness_only += 1
                lost = True   # (its bytes and where they cut in are timing: not compared either,
                continue      # also on a side whose model cannot follow; the trace ends before the
                              # guard's `debug 0`, so before the fence line)
            if side.model.tainted:
                unjudged[len(answers) - 1] = keep
                continue   # the facts do not say what this line does: liveness only
            res = match_stream(plan.expected, got, self._allowed(side, plan.debug))
            if res.problems and keep is not None:
                # Bytes a full TX ring dropped are no finding (docs/FIRMWARE-BEHAVIOUR.md#fb-tx-ring);
                # anything else is.
                lossy = match_lossy(plan.expected, got, self._allowed(side, plan.debug), keep)
                if lossy is not None:
                    res, lost = lossy, True
                    self.stats.ring_lossy += 1
            compared[-1] = without_torn(got, res)
            observe(side.model, res, plan.states, self.stats.count)
            side.model.ports[:] = plan.states[-1]   # reports seen (once-selections) move the model on
            self._judge(side, res.problems, {"step": plan.blob, "expected": plan.expected, "received": got})
            self._check_records(side, before, plan.fates)
        if len(self.sides) == 2 and not lost:   # (drops, a raw trace: timing; each side judged its own)
            self._differential(first.datas, compared, leading, settling, unjudged)
        return answers

    def _check_records(self, side: Side, start: int, fates: List[LineFate]) -> None:
        """White-box part of the fate oracle, for targets that report what each line ran
        (the in-process emulator's ``line_records``): the same commands, unknown token and Error."""
        records = getattr(side.link.target, "line_records", None)
        if records is None or side.model.tainted:
            return
        got = records[start:]
        self.stats.count(FATE.name)
        for fate, rec in zip(fates, got):
            want = (fate.commands + ([fate.failed] if fate.failed and not fate.unknown else []),
                    [fate.unknown] if fate.unknown else [], fate.error, fate.comment)
            have = (list(rec.commands), list(rec.unknown), bool(rec.error), bool(rec.comment))
            if want != have:
                self.fail(FATE.name, f"{side.label}: line {fate.raw!r} ran {have[0]} (unknown {have[1]}, "
                                     f"Error {have[2]}, comment {have[3]}); the facts say {want[0]} "
                                     f"(unknown {want[1]}, Error {want[2]}, comment {want[3]})",
                          {"step": fate.raw, "received": b""})
        if len(got) != len(fates):
            self.fail(FATE.name, f"{side.label}: {len(got)} lines processed, the model counts {len(fates)}",
                      {"step": b"", "received": b""})

    def wait(self, ms: int) -> None:
        """Let HAT time pass; what arrives meanwhile must be asynchronous lines the state allows."""
        # A wait long enough for the ring to drain leaves only what still streams queued.
        self._queued = [0 if ms * WIRE_BYTES_PER_MS >= q else q for q in self._queued]
        for i, side in enumerate(self.sides):
            try:
                out = side.link.wait(ms)
            except (ExchangeTimeout, TargetError) as exc:
                self.firmware_reports(side, b"", getattr(exc, "received", b""))
                raise
            self.firmware_reports(side, b"", out)
            self._note_kinds(out)
            self._track(side, out)
            self._dump_open[i] = open_dump(self._dump_open[i] + out)
            ports = [p.copy() for p in side.model.ports]
            if side.model.tainted:
                continue
            before = [p.copy() for p in side.model.ports]
            res = match_stream([], out, self._allowed(side))
            observe(side.model, res, [ports], self.stats.count)
            side.model.ports[:] = ports
            expect_reports(side.model, ms, before, res, self.stats.count)
            events = getattr(side.link.target, "drive_events", None)
            check_drive(events, side.model, ms, res, self.stats.count)
            self._judge(side, res.problems, {"step": f"@wait {ms}", "received": out})

    # -- checks --------------------------------------------------------------------------------
    def _note_kinds(self, out: bytes) -> None:
        kinds = _kinds_of(out)
        self.kinds_seen |= kinds
        self.stats.responses |= kinds

    def _allowed(self, side: Side, debug: Optional[int] = None) -> frozenset:
        if side.model.tainted:
            return side.allowed(None)
        return side.allowed(side.model.debug if debug is None else debug)

    def _judge(self, side: Side, problems: List[Problem], details: dict) -> None:
        """The problems the model's oracles found in one side's answer, with those of every added
        oracle's check (registry.py): the first by priority is the finding."""
        step = details["step"]
        for judge in self._per_answer:
            self.stats.count(judge.name)
        if self._checks:
            answer = Answer(side.label, side.profile.name, step if isinstance(step, bytes) else b"",
                            details["received"])
            problems = problems + [p for check in self._checks for p in check(answer)]
        if not problems:
            return
        first = min(problems, key=lambda p: oracle_named(p.oracle).priority)
        blob = step if isinstance(step, bytes) else step.encode()
        message, more = stream_message(side.label, first.message, first.at, blob, details.get("expected", ()),
                                       details["received"])
        self.fail(first.oracle, message, dict(details, **more))

    def _track(self, side: Side, out: bytes) -> None:
        """Differential mode: the connection lines a side printed (reconnecting.py)."""
        # (every line either tracker reads has "connect", "established" or "MQ overrun" in it;
        # an answer with none of them is not split into lines at all)
        if len(self.sides) == 2 and (b"connect" in out or b"established" in out or b"MQ overrun" in out):
            events = synchronous_part(out)[1]
            # (both kept per target: a kept-open target's next run knows them; reconnecting.py, setup_loss.py)
            reconnecting_on(side.link.target).feed(events, side.link.target_now)
            for_target(side.link.target).feed(events)

    def _settling(self) -> FrozenSet[int]:
        """The ports a side is setting up again now (reconnecting.py)."""
        return frozenset().union(*(reconnecting_on(side.link.target).ports(side.link.target_now)
                                   for side in self.sides))

    def _differential(self, datas: Sequence[bytes], answers: List[bytes],
                      leading: Sequence[bytes] = (b"", b""),
                      settling_at_start: FrozenSet[int] = frozenset(),
                      ring_keeps: Sequence[Optional[int]] = (None, None)) -> None:
        """``leading``: per side, the first lines of a connect dump the last read ended inside of
        (differential.open_dump), put back in front of the rest, which begins this answer.
        ``settling_at_start``: the ports a side was setting up again when the step began.
        ``ring_keeps``: per side, the bytes of its answer that always fit in its TX ring where the
        ring may have dropped the rest unjudged (None: all of it counts)."""
        a_side, b_side = self.sides
        a, b = answers
        self.stats.count(DIFFERENTIAL.name)
        # The fence's own answer names each release: compare up to it.
        a_cut = leading[0] + (a[:a.rfind(a_side.fence_line)] if a_side.fence_line in a else a)
        b_cut = leading[1] + (b[:b.rfind(b_side.fence_line)] if b_side.fence_line in b else b)
        also: FrozenSet[int] = frozenset()
        diff = self._first_difference(a_cut, b_cut, also)
        settling: FrozenSet[int] = frozenset()
        if diff is not None:
            # A port one side is setting up again lists as its clock has it: timing (reconnecting.py).
            settling = self._settling() | settling_at_start
            if settling - self._apart:
                also = settling
                diff = self._first_difference(a_cut, b_cut, also)
                self.stats.reconnect_apart += diff is None
        if diff is not None:
            # A port whose set-up lost messages to a side's full queue (`MQ overrun!`) lists what that
            # side received, until it sets up again: timing (setup_loss.py).
            partial = frozenset().union(*(for_target(side.link.target).ports() for side in self.sides))
            if partial - self._apart - settling:
                also = settling | partial
                diff = self._first_difference(a_cut, b_cut, also)
                self.stats.setup_loss_apart += diff is None
        if diff is not None and any(k is not None for k in ring_keeps):
            # Past the bytes that always fit, a side's full ring may have dropped output
            # (fuzz/model/tx_ring.py)
            # that its model, unsettled by the facts, could not judge: a difference there is no finding.
            apart = frozenset(self._apart | also)
            passed = [None if k is None else sync_bytes_before(cut, diff[0], apart) - len(lead)
                      for k, cut, lead in zip(ring_keeps, (a_cut, b_cut), leading)]
            if any(k is not None and n is not None and n >= k for k, n in zip(ring_keeps, passed)):
                self.stats.ring_unjudged += 1
                return
        if diff is not None:
            step = b"".join(datas) + FENCE
            message, more = differential_message((a_side.label, b_side.label), step, *diff)
            self.fail(DIFFERENTIAL.name, message, dict(more, step=step, received=a, received_other=b))

    def _first_difference(self, a: bytes, b: bytes, also: FrozenSet[int]
                          ) -> Optional[Tuple[int, Optional[bytes], Optional[bytes]]]:
        """The first difference, leaving out the ports in ``also`` and those whose light matrix one
        side has lost: a timing boundary (differential.parted_matrix), whose port's `list` block is
        not compared for the rest of the run (found here, whichever port's difference came first)."""
        while True:
            diff = first_difference(a, b, frozenset(self._apart | also), self._identity)
            port = None if diff is None else parted_matrix(diff[1], diff[2])
            if port is None or port in self._apart:
                return diff
            self._apart.add(port)
            self.stats.matrix_apart += 1

    def firmware_reports(self, side: Side, blob: bytes, received: bytes) -> None:
        """A firmware in the loop that crashed or reported (a sanitizer) while it took ``blob``: a
        finding (``crash`` or ``sanitizer``), never a liveness one; reports the run's suppressions
        cover are not (sil/sanitizer_reports.py)."""
        take = getattr(side.link.target, "take_firmware_reports", None)
        if take is None:
            return
        self.stats.count(CRASH.name)
        self.stats.count(SANITIZER.name)
        found = [r for r in take() if r.suppressed_by is None]
        if not found:
            return
        fatal = next((r for r in found if r.fatal), None)
        message = found[0].first + (f" (then the firmware crashed: {fatal.first})"
                                    if fatal is not None and fatal is not found[0] else "")
        self.fail((CRASH if fatal is not None else SANITIZER).name, f"{side.label}: {message}",
                  {"step": blob, "received": received, "reports": [r.text for r in found]})

    def fail(self, oracle: str, message: str, details: dict) -> NoReturn:
        """Raises the finding of the oracle named ``oracle`` (fuzz/oracles/registry.py)."""
        traces = [s.link.trace.copy() for s in self.sides]
        profiles = [s.profile.name for s in self.sides]
        # ``fresh``: the run began on a freshly started target (not one earlier runs left open).
        oracle_named(oracle).fail(message, traces, dict(details, profiles=profiles, fresh=self.fresh))

