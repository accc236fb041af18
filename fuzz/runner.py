"""One checked run: open the target(s), bring them to a known state, then exchange input and
check every oracle after each step. Used by the campaign (fuzz/campaign.py) and by the
replay of a finding's script (fuzz/replay.py), so a replay judges exactly as the fuzzer did.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence, Set, Tuple

from ..harness.events import line_kind
from ..harness.targets.base import Target, TargetError
from ..protocol.profiles import Profile
from .differential import compare_answers
from .expect import LineFate
from .link import FENCE, Link, LinkTimeout
from .model import HatModel
from .oracles import raise_finding
from .portmodel import PortModel, expected_duty
from .stepplan import plan_step
from .stream import MatchResult, Problem, allowed_kinds, match_stream, without_torn

__all__ = ["Runner", "Side", "Stats", "PRELUDE"]

# Puts any HAT into a state the model knows: echo and debug off, no selection, port 0.
PRELUDE = b"echo 0\rdebug 0\rport 3\rselect\rport 2\rselect\rport 1\rselect\rport 0\rselect\r"
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
    sent_bytes: int = 0           # over the first target's wire, fences included
    recv_bytes: int = 0
    left_out: int = 0             # inputs not sent: their answer alone would overflow the TX ring
    startup_s: float = 0.0        # time spent starting kept-open targets (not fuzzing)
    checking_s: float = 0.0       # time spent confirming and reducing findings (not fuzzing)
    liveness_only: int = 0        # steps judged on liveness alone (a raw serial trace on a timed link)
    on_progress: Optional[Callable[[Stats], None]] = None
    on_note: Optional[Callable[[str], None]] = None     # what the campaign is doing besides fuzzing

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




def _selection(p: PortModel, selrate_engine: bool) -> str:
    """A port's selection as a finding names it."""
    form = "/".join(p.report_forms()) if p.mode >= 0 else "-"
    return (f"mode {p.mode} form {form} rate {p.rate} "
            f"(reporting {'on' if p.reporting(selrate_engine) else 'off'})")


class Runner:
    """The sides of one run and the checks made after each step (raise a Finding on failure)."""

    def __init__(self, openers: Sequence[Tuple[str, Callable[[], Target], Profile]], fence_s: float = 2.0,
                 fresh: bool = True, stats: Optional[Stats] = None,
                 devices: Optional[Dict[int, Optional[tuple]]] = None, keep_open: bool = False):
        """``openers`` may hand out targets that are already open (a campaign reusing one
        target for many runs); ``keep_open``: :meth:`close` leaves them open."""
        self.stats = stats or Stats()
        self.sides: List[Side] = []
        self.kinds_seen: Set[str] = set()
        self.fresh = fresh
        self.keep_open = keep_open
        self.settled = False      # the targets come from a run that ended cleanly (see start)
        for label, opener, profile in openers:
            try:
                target = opener()
            except TargetError as exc:
                self.fail("liveness", f"{label}: the target could not be opened: {exc}", {})
            side = Side(label, target, profile, fence_s)
            if devices is not None and fresh:
                # The layout the target booted with (known only for targets started fresh).
                side.model = HatModel(profile, devices)
            self.sides.append(side)
            if target.is_open:
                continue
            try:
                target.open()
            except TargetError as exc:
                self.fail("liveness", f"{label}: the target could not be opened: {exc}", {})

    def start(self, prelude: bytes = PRELUDE) -> None:
        """Drain the start-up output and send the prelude (not judged: the state before it is unknown).
        A target that a clean run just left (``settled``) answers at once: no drain, no sync; what
        is still on its way ends up in the prelude's answer."""
        for side in self.sides:
            try:
                if not self.settled:
                    side.link.drain()
                    side.link.sync(side.fence_line)
                side.link.exchange(prelude, side.fence_line, 1)
            except LinkTimeout as exc:
                self.fail("liveness", f"{side.label}: no answer after the prelude: {exc}",
                          {"step": prelude, "received": exc.received})
            side.model.feed(prelude)
            side.model.feed(FENCE)
            if not self.fresh:
                # An earlier run left this HAT: the prelude resets the selections, not the combi
                # tables (a report may come as C<m> where this run set no combi).
                for p in side.model.ports:
                    p.known = False
                    p.forget_combis()

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
    def exchange(self, datas: Sequence[bytes], guard: bool = False) -> List[bytes]:
        """One step: the inputs back to back and one fence, written to every side before any
        answer is read; then each answer is checked. With ``guard``, inputs that would leave
        debug bit 1 set get :data:`DEBUG_OFF` (decided on the first side's model, so every side
        receives the same bytes). Returns each side's answer."""
        first = plan_step(self.sides[0].model, datas, guard)
        plans = [first] + [plan_step(side.model, first.datas) for side in self.sides[1:]]
        records = []
        for side, plan in zip(self.sides, plans):
            records.append(len(getattr(side.link.target, "line_records", ())))
            try:
                side.link.send(plan.blob)
            except TargetError as exc:
                self.fail("liveness", f"{side.label}: the target went away: {exc}",
                          {"step": plan.blob, "received": b""})
        answers: List[bytes] = []
        compared: List[bytes] = []       # what the differential oracle compares (echo made whole)
        for side, plan, before in zip(self.sides, plans, records):
            self.stats.count("liveness")
            try:
                got = side.link.receive(side.fence_line, plan.fences, plan.size, len(plan.blob),
                                        prompt=None if side.model.tainted else bool(side.model.echo))
            except LinkTimeout as exc:
                self.fail("liveness", f"{side.label}: {exc}", {"step": plan.blob, "received": exc.received})
            answers.append(got)
            compared.append(got)
            self._note_kinds(got)
            if side.model.tainted:
                continue   # the facts do not say what this line does: liveness only
            if plan.debug & 1 and side.link.timed:
                # The raw serial trace (debug bit 1, §7.4) has no line structure; where input
                # takes time to arrive it runs until the guard's `debug 0` is read. Liveness only.
                side.model.ports[:] = plan.states[-1]
                self.stats.liveness_only += 1
                continue      # (the trace ends before the guard's `debug 0`, so before the fence line)
            res = match_stream(plan.expected, got, self._allowed(side, plan.debug))
            compared[-1] = without_torn(got, res)
            self._observe(side, res, plan.states)
            side.model.ports[:] = plan.states[-1]   # reports seen (once-selections) move the model on
            self._judge(side, res.problems, {"step": b"".join(plan.datas), "expected": plan.expected,
                                             "received": got})
            self._check_records(side, before, plan.fates)
        if len(self.sides) == 2:
            self._differential(first.datas, compared)
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
                    "state", f"port {port} drives {last[port]!r}; direct PWM at setpoint "
                             f"{p.constant} with plimit {limit}/65536 should drive {want!r}"))

    def _expect_reports(self, side: Side, ms: int, before: List[PortModel], res: MatchResult) -> None:
        """The other half of the state oracle: a plain `select <m>` on an established device that
        has mode m must report within a wait that is long enough (first report about one period
        after the first data, §6.2). Only clear cases are judged: no combi, no raw writes to the
        device, no link change, a rate well inside the wait."""
        if ms < 300:
            return
        seen = {(ev.port, _REPORT_FORMS[ev.kind](ev.fields)) for _i, ev in res.asynchronous
                if ev.kind in _REPORT_FORMS}
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
            forms = p.report_forms()
            if not any((port, form) in seen for form in forms):
                want = " or ".join(f"P{port}{form}" for form in forms)
                res.problems.append(Problem(
                    "state", f"port {port} has mode {p.mode} selected (rate {p.rate}) on an "
                             f"established device, but no {want} report came in {ms} ms"))

    # -- checks --------------------------------------------------------------------------------
    def _note_kinds(self, out: bytes) -> None:
        kinds = _kinds_of(out)
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
                ident = ev.fields.get("id")
                type_id = ident if ev.kind == "established" and isinstance(ident, int) else None
                # Every state of the step: which of them the line came after is not known.
                for p in [model.ports[port]] + [s[port] for s in states]:
                    p.link_changed(type_id)
                continue
            form_of = _REPORT_FORMS.get(ev.kind)
            if form_of is None:
                continue
            self.stats.count("state")
            form = form_of(ev.fields)
            # The form follows the HAT's own selection and combi table (§6.1), whatever the
            # device was sent (write1/write2 change what it sends, not how the HAT prints it).
            sources = [s[port] for s in states
                       if not s[port].known or (s[port].reporting(model.selrate_engine)
                                                and form in s[port].report_forms())]
            if not sources:
                before, after = (_selection(s[port], model.selrate_engine) for s in (states[0], states[-1]))
                whose = before if before == after else f"{before} before the step, {after} after it"
                res.problems.append(Problem(
                    "state", f"report {ev.text!r} from port {port}, whose selection is {whose}"))
                continue
            # The report ends the once-selection that printed it, the first that could have: a
            # report already due when a later select ran belongs to the earlier one (§6.2).
            for s in states:
                if s[port].selection == sources[0].selection:
                    model.report_seen(s[port])

    def _judge(self, side: Side, problems: List[Problem], details: dict) -> None:
        for oracle in ("hygiene", "fate", "state"):
            self.stats.count(oracle)
        if not problems:
            return
        first = sorted(problems, key=lambda p: _PRIORITY.index(p.oracle))[0]
        self.fail(first.oracle, f"{side.label}: {first.message}", details)

    def _differential(self, datas: Sequence[bytes], answers: List[bytes]) -> None:
        a_side, b_side = self.sides
        a, b = answers
        self.stats.count("differential")
        # The fence's own answer names each release: compare up to it.
        a_cut = a[:a.rfind(a_side.fence_line)] if a_side.fence_line in a else a
        b_cut = b[:b.rfind(b_side.fence_line)] if b_side.fence_line in b else b
        diff = compare_answers(a_cut, b_cut, a_side.label, b_side.label)
        if diff is not None:
            step = b"".join(datas)
            self.fail("differential", f"input {step!r}: {diff}",
                      {"step": step, "received": a, "received_other": b})

    def fail(self, oracle: str, message: str, details: dict) -> None:
        traces = [s.link.trace.copy() for s in self.sides]
        profiles = [s.profile.name for s in self.sides]
        # ``fresh``: the run began on a freshly started target (not one earlier runs left open).
        raise_finding(oracle, message, traces, dict(details, profiles=profiles, fresh=self.fresh))

