"""One checked run: open the target(s), bring them to a known state, then exchange input and
check every oracle after each step. Used by the state machine (fuzz/machine.py) and by the
replay of a finding's script (fuzz/replay.py), so a replay judges exactly as the fuzzer did.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence, Set, Tuple

from ..harness.events import line_kind
from ..harness.targets.base import Target, TargetError
from ..protocol.profiles import Profile
from .differential import compare_answers
from .link import FENCE, Link, LinkTimeout
from .model import Expect, HatModel, LineFate, PortModel, established, expected_duty, joined
from .oracles import raise_finding
from .stream import MatchResult, Problem, allowed_kinds, match_stream

__all__ = ["Runner", "Side", "Stats", "PRELUDE", "DEBUG_OFF", "guard_debug", "Lookahead"]

# Puts any HAT into a state the model knows: echo and debug off, no selection, port 0.
PRELUDE = b"echo 0\rdebug 0\rport 3\rselect\rport 2\rselect\rport 1\rselect\rport 0\rselect\r"
# Debug bit 1 is a raw serial trace with no line structure (§7.4): after any input that leaves
# it set, this is sent at once so the line-level oracles stay meaningful.
DEBUG_OFF = b"debug 0\r"
_PRIORITY = ("liveness", "hygiene", "fate", "state")
_LINK_KINDS = {"connecting", "established", "disconnected", "timeout", "checksum_error", "too_many_errors",
               "framing_error"}
_REPORT_FORMS = {"mode_data": lambda f: f"M{f['mode']}", "combi_data": lambda f: f"C{f['index']}",
                 "var_data": lambda f: "V"}


@dataclass
class Stats:
    """Campaign figures, shared by every run."""

    examples: int = 0
    executions: int = 0           # inputs sent
    lines: int = 0                # CR-terminated lines sent (fences excluded)
    productions: Set[str] = field(default_factory=set)
    responses: Set[str] = field(default_factory=set)
    checks: Dict[str, int] = field(default_factory=dict)
    on_progress: Optional[Callable[[Stats], None]] = None

    def count(self, oracle: str, n: int = 1) -> None:
        self.checks[oracle] = self.checks.get(oracle, 0) + n


class Side:
    """One target, its link and the model of its state."""

    def __init__(self, label: str, target: Target, profile: Profile, fence_s: float):
        self.label, self.profile = label, profile
        self.link = Link(target, label, fence_s)
        self.model = HatModel(profile)
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


def _count_fences(items: Sequence[Expect]) -> int:
    return sum(1 for it in items if it.kind == "exact" and it.what == "version line")


def _size(items: Sequence[Expect]) -> int:
    return sum(len(it.data) if it.kind == "exact" else (4000 if it.kind == "listing" else 80) for it in items)


@dataclass
class _Plan:
    """One input of a batch as the model predicts it. Its answer (and any line printed
    meanwhile) is judged by the port states before and after it and the debug bits of either."""

    pre: List[PortModel]
    expected: List[Expect]        # up to and with its fence's answer
    post: List[PortModel]
    debug: int
    fates: List[LineFate]         # every line it ends, the fence's included


def _plan(model: HatModel, data: bytes, guard: bool = False) -> Tuple[bytes, _Plan]:
    """Feed ``data`` and its fence to ``model``. With ``guard``, :data:`DEBUG_OFF` is appended to
    the data (and fed) when it leaves debug bit 1 set. Returns the data to send and its plan."""
    pre = [p.copy() for p in model.ports]
    debug_before = model.debug
    items, fates = model.feed(data)
    if guard and model.debug & 1:
        data += DEBUG_OFF
        more, more_fates = model.feed(DEBUG_OFF)
        items = joined(items, more)          # what feeding ``data + DEBUG_OFF`` at once predicts
        fates += more_fates
    fence_items, fence_fates = model.feed(FENCE)
    post = [p.copy() for p in model.ports]
    return data, _Plan(pre, items + fence_items, post, debug_before | model.debug, fates + fence_fates)


@dataclass
class Lookahead:
    """What :func:`guard_debug` predicted on its probe, for :meth:`Runner.exchange`: sent next
    from the same state, the same inputs need not be predicted twice (H10 profile: the second
    prediction was a fifth of the fuzzer's time). Used at most once."""

    model: HatModel               # the model the probe was cloned from
    before: HatModel              # its state when the probe was taken
    datas: List[bytes]
    plans: List[_Plan]
    after: Optional[HatModel]     # the probe, fed with every input and fence (None once used)

    def take(self, model: HatModel, datas: Sequence[bytes]) -> Optional[List[_Plan]]:
        """The plans, with ``model`` moved on as feeding them would, if ``model`` is the one
        they were made for, still in that state, and about to send these inputs; else None."""
        if (self.after is None or model is not self.model or self.datas != list(datas)
                or not model.same_state(self.before)):
            return None
        model.adopt(self.after)
        self.after = None         # adopt() took over its ports and buffers
        return self.plans


def guard_debug(model: HatModel, datas: Sequence[bytes]) -> Tuple[List[bytes], Lookahead]:
    """The inputs with :data:`DEBUG_OFF` appended wherever one would leave debug bit 1 set,
    and the predictions made on the way (pass them to :meth:`Runner.exchange`)."""
    probe = model.clone()
    out: List[bytes] = []
    plans: List[_Plan] = []
    for data in datas:
        data, plan = _plan(probe, data, guard=True)
        out.append(data)
        plans.append(plan)
    return out, Lookahead(model, model.clone(), list(out), plans, probe)


class Runner:
    """The sides of one run and the checks made after each step (raise a Finding on failure)."""

    def __init__(self, openers: Sequence[Tuple[str, Callable[[], Target], Profile]], fence_s: float = 2.0,
                 fresh: bool = True, stats: Optional[Stats] = None,
                 devices: Optional[Dict[int, Optional[tuple]]] = None):
        self.stats = stats or Stats()
        self.sides: List[Side] = []
        self.kinds_seen: Set[str] = set()
        self.fresh = fresh
        for label, opener, profile in openers:
            side = Side(label, opener(), profile, fence_s)
            if devices is not None and fresh:
                # The layout the target booted with (known only for targets started fresh).
                side.model = HatModel(profile, devices)
            self.sides.append(side)
            try:
                side.link.target.open()
            except TargetError as exc:
                self.fail("liveness", f"{label}: the target could not be opened: {exc}", {})

    def start(self, prelude: bytes = PRELUDE) -> None:
        """Drain the start-up output and send the prelude (not judged: the state before it is unknown)."""
        for side in self.sides:
            side.link.drain()
            try:
                side.link.sync(side.fence_line)
                side.link.exchange(prelude, side.fence_line, 1)
            except LinkTimeout as exc:
                self.fail("liveness", f"{side.label}: no answer after the prelude: {exc}",
                          {"step": prelude, "received": exc.received})
            side.model.feed(prelude)
            side.model.feed(FENCE)
            if not self.fresh:
                for p in side.model.ports:
                    p.known = False

    def close(self) -> None:
        for side in self.sides:
            side.close()

    # -- steps ---------------------------------------------------------------------------------
    def exchange(self, datas: Sequence[bytes], lookahead: Optional[Lookahead] = None) -> List[List[bytes]]:
        """Send every input followed by a fence (back to back), then check each answer.
        ``lookahead``: what :func:`guard_debug` predicted for these inputs, if it did."""
        answers: List[List[bytes]] = []
        for side in self.sides:
            # Pipelined inputs are all fed to the model first; each keeps the state before and
            # after it, which is what its answer (and any line printed meanwhile) is judged by.
            records_before = len(getattr(side.link.target, "line_records", ()))
            plans = (lookahead.take(side.model, datas) if lookahead is not None else None) \
                or [_plan(side.model, data)[1] for data in datas]
            fates = [fate for plan in plans for fate in plan.fates]
            self.stats.count("liveness")
            try:
                got = side.link.exchange_batch(
                    datas, side.fence_line, [max(1, _count_fences(p.expected)) for p in plans],
                    [_size(p.expected) for p in plans],
                    prompt=None if side.model.tainted else bool(side.model.echo))  # H10: no idle wait
            except LinkTimeout as exc:
                self.fail("liveness", f"{side.label}: {exc}",
                          {"step": b"".join(datas), "received": exc.received})
            answers.append(got)
            for plan, data, out in zip(plans, datas, got):
                self._note_kinds(out)
                if side.model.tainted:
                    continue   # the facts do not say what this line does: liveness only
                res = match_stream(plan.expected, out, self._allowed(side, plan.debug))
                self._observe(side, res, [plan.pre, plan.post])
                if len(datas) == 1:
                    side.model.ports[:] = plan.post   # reports seen (once-selections) move the model on
                self._judge(side, res.problems, {"step": data, "expected": plan.expected, "received": out})
            self._check_records(side, records_before, fates)
        if len(self.sides) == 2:
            self._differential(datas, answers)
        return answers

    def _check_records(self, side: Side, start: int, fates: List[LineFate]) -> None:
        """White-box part of the fate oracle, for targets that report what each line ran
        (the in-process emulator's ``line_records``): the same commands, unknown token and Error."""
        records = getattr(side.link.target, "line_records", None)
        if records is None or side.model.tainted:
            return
        got = records[start:]
        self.stats.count("fate")
        for fate, rec in zip(fates, got):
            want = (fate.commands + ([fate.failed] if fate.failed and not fate.unknown else []),
                    [fate.unknown] if fate.unknown else [], fate.error, fate.comment)
            have = (list(rec.commands), list(rec.unknown), bool(rec.error), bool(rec.comment))
            if want != have:
                self.fail("fate", f"{side.label}: line {fate.raw!r} ran {have[0]} (unknown {have[1]}, "
                                  f"Error {have[2]}, comment {have[3]}); the facts say {want[0]} "
                                  f"(unknown {want[1]}, Error {want[2]}, comment {want[3]})",
                          {"step": fate.raw, "received": b""})
        if len(got) != len(fates):
            self.fail("fate", f"{side.label}: {len(got)} lines processed, the model counts {len(fates)}",
                      {"step": b"", "received": b""})

    def wait(self, ms: int) -> None:
        """Let HAT time pass; what arrives meanwhile must be asynchronous lines the state allows."""
        for side in self.sides:
            out = side.link.wait(ms)
            self._note_kinds(out)
            ports = [p.copy() for p in side.model.ports]
            if side.model.tainted:
                continue
            before = [p.copy() for p in side.model.ports]
            res = match_stream([], out, self._allowed(side))
            self._observe(side, res, [ports])
            side.model.ports[:] = ports
            self._expect_reports(side, ms, before, res)
            self._check_drive(side, ms, res)
            self._judge(side, res.problems, {"step": f"@wait {ms}", "received": out})

    def _check_drive(self, side: Side, ms: int, res: MatchResult) -> None:
        """State oracle on the drive, for targets that show it (the in-process emulator's
        ``drive_events``): a port in direct-PWM mode with a known constant setpoint settles at the
        duty §7.3 gives for it and the port's plimit (per release); a coasting port coasts."""
        events = getattr(side.link.target, "drive_events", None)
        if events is None or ms < 30:
            return
        changed = {ev.port for _i, ev in res.asynchronous if ev.kind in _LINK_KINDS}
        last: Dict[int, object] = {}
        for ev in events:
            if ev.get("dir") == "pwm":
                last[int(ev["port"])] = ev.get("value")
        model = side.model
        for port, p in enumerate(model.ports):
            if p.device_modes <= 0 or port in changed or port not in last:
                continue
            want = expected_duty(side.profile, p, model.plimit)
            if want is None:
                continue
            self.stats.count("state")
            if last[port] != want:
                limit = p.plimit if model.per_port_plimit else model.plimit
                res.problems.append(Problem(
                    "state", f"{side.label}: port {port} drives {last[port]!r}; direct PWM at setpoint "
                             f"{p.constant} with plimit {limit}/65536 should drive {want!r}"))

    def _expect_reports(self, side: Side, ms: int, before: List[PortModel], res: MatchResult) -> None:
        """The other half of the state oracle: a plain `select <m>` on an established device that
        has mode m must report within a wait that is long enough (first report about one period
        after the first data, §6.2). Only clear cases are judged: no combi, no raw writes to the
        device, no link change, a rate well inside the wait."""
        if ms < 300:
            return
        seen = {(ev.port, ev.kind, ev.fields.get("mode")) for _i, ev in res.asynchronous}
        changed = {ev.port for _i, ev in res.asynchronous if ev.kind in _LINK_KINDS}
        for port, p in enumerate(before):
            if not (p.known and not p.tampered and not p.var and 0 <= p.mode < min(p.device_modes, 8)
                    and not p.combi.get(p.mode) and port not in changed):
                continue
            if side.model.selrate_engine:
                if not 0 <= p.rate <= ms - 200:
                    continue
            elif p.once:
                continue
            self.stats.count("state")
            if (port, "mode_data", p.mode) not in seen:
                res.problems.append(Problem(
                    "state", f"{side.label}: port {port} has mode {p.mode} selected (rate {p.rate}) on an "
                             f"established device, but no P{port}M{p.mode} report came in {ms} ms"))

    # -- checks --------------------------------------------------------------------------------
    def _note_kinds(self, out: bytes) -> None:
        kinds = {line_kind(line) for line in out.split(b"\r\n")[:-1]}
        self.kinds_seen |= kinds
        self.stats.responses |= kinds

    def _allowed(self, side: Side, debug: Optional[int] = None) -> frozenset:
        if side.model.tainted:
            return side.allowed(None)
        return side.allowed(side.model.debug if debug is None else debug)

    def _observe(self, side: Side, res: MatchResult, states: List[List[PortModel]]) -> None:
        """The state oracle over asynchronous lines: reports only from selections that allow
        them, in the selected form; connects and disconnects reset what the model knows."""
        model = side.model
        for _idx, ev in res.asynchronous:
            port = ev.port
            if port is None or not 0 <= port <= 3:
                continue
            if ev.kind in _LINK_KINDS:
                model.saw_link_change(port)
                for s in states:
                    s[port].combi.clear()
                    s[port].known = False
                    s[port].device_modes = 0
                ident = ev.fields.get("id")
                if ev.kind == "established" and isinstance(ident, int):
                    for p in [model.ports[port]] + [s[port] for s in states]:
                        established(p, ident)
                continue
            form_of = _REPORT_FORMS.get(ev.kind)
            if form_of is None:
                continue
            self.stats.count("state")
            form = form_of(ev.fields)
            ok = any(not s[port].known or (s[port].reporting(model.selrate_engine)
                                           and s[port].report_form() == form) for s in states)
            if not ok:
                s = states[-1][port]
                res.problems.append(Problem(
                    "state", f"{side.label}: report {ev.text!r} from port {port}, whose selection is "
                             f"mode {s.mode} form {s.report_form() if s.mode >= 0 else '-'} rate {s.rate} "
                             f"(reporting {'on' if s.reporting(model.selrate_engine) else 'off'})"))
            for s in states:
                model.report_seen(s[port])

    def _judge(self, side: Side, problems: List[Problem], details: dict) -> None:
        for oracle in ("hygiene", "fate", "state"):
            self.stats.count(oracle)
        if not problems:
            return
        first = sorted(problems, key=lambda p: _PRIORITY.index(p.oracle))[0]
        self.fail(first.oracle, f"{side.label}: {first.message}", details)

    def _differential(self, datas: Sequence[bytes], answers: List[List[bytes]]) -> None:
        a_side, b_side = self.sides
        for data, a, b in zip(datas, answers[0], answers[1]):
            self.stats.count("differential")
            # The fence's own answer names each release: compare up to it.
            a_cut = a[:a.rfind(a_side.fence_line)] if a_side.fence_line in a else a
            b_cut = b[:b.rfind(b_side.fence_line)] if b_side.fence_line in b else b
            diff = compare_answers(a_cut, b_cut, a_side.label, b_side.label)
            if diff is not None:
                self.fail("differential", f"input {data!r}: {diff}",
                          {"step": data, "received": a, "received_other": b})

    def fail(self, oracle: str, message: str, details: dict) -> None:
        traces = [s.link.trace.copy() for s in self.sides]
        profiles = [s.profile.name for s in self.sides]
        raise_finding(oracle, message, traces, dict(details, profiles=profiles))

