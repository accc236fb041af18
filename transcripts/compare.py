"""Comparison rules for transcripts: which HAT output counts as "the same" on replay.

Two transcripts are compared as sequences of *output lines* (the HAT byte stream split at
CRLF; a prompt such as ``P0>`` joins the echo that follows it, because where a target's
output is cut into chunks is an accident of timing, not behaviour). Each line has an
event class (from the session's line classifier: ``vin``, ``mode_data``, ``pid_debug`` ...)
and each class has a rule:

``exact``          the bytes must be equal (the default);
``pattern:REGEX``  the actual line must match REGEX in full (the recorded one only places it);
``tolerance:N``    the text around the numbers must be equal and each number within N
                   (``N%``: relative) — for analogue readings: vin, positions, speeds;
``ignore``         lines of the class are left out on both sides (e.g. data lines).

Alignment uses difflib on keys that already ignore what the rule allows to differ, so a
tolerated reading cannot push the rest of the diff out of step.
"""
from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Tuple

from ..harness.line_splitter import expected_echo
from ..harness.transcript import CRLF, field_bytes

__all__ = ["Rule", "RuleSet", "Unit", "Difference", "Comparison", "parse_rule", "parse_rule_option",
           "output_units", "compare_units", "CLASS_ALIASES", "ASYNC_CLASSES", "default_classifier"]

# Names that stand for several event classes on the command line.
CLASS_ALIASES: Dict[str, Tuple[str, ...]] = {
    "data": ("mode_data", "combi_data", "var_data"),
    "debug": ("pid_debug", "data_debug"),
}

# Lines the HAT prints on its own schedule rather than in answer to a host line.
ASYNC_CLASSES = frozenset({
    "mode_data", "combi_data", "var_data", "pid_debug", "data_debug", "signature_debug", "unknown_debug",
    "connecting", "baud", "established", "disconnected", "timeout", "checksum_error", "framing_error",
    "too_many_errors", "button", "pulse_done", "ramp_done", "port_fault", "motor_fault", "fault_dump",
    "fault_read_error", "mq_overrun", "deltat",
})

# A number standing on its own: not part of a word such as P0, M1 or the hex 00000BB8.
_NUMBER = re.compile(r"(?<![A-Za-z0-9.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:E-?\d+)?(?![A-Za-z0-9.])")


def _skeleton(text: str) -> Tuple[str, List[float]]:
    nums = [float(m.group(0)) for m in _NUMBER.finditer(text)]
    return _NUMBER.sub("#", text), nums


@dataclass(frozen=True)
class Rule:
    kind: str                      # exact | pattern | tolerance | ignore
    pattern: Optional[str] = None  # for pattern
    tolerance: float = 0.0         # for tolerance
    relative: bool = False         # tolerance given as N%

    def __str__(self) -> str:
        if self.kind == "pattern":
            return f"pattern:{self.pattern}"
        if self.kind == "tolerance":
            return f"tolerance:{self.tolerance:g}{'%' if self.relative else ''}"
        return self.kind

    def key(self, cls: str, text: str) -> str:
        """What must be equal for two lines to be aligned with each other."""
        if self.kind == "exact":
            return f"{cls}\0{text}"
        if self.kind == "tolerance":
            return f"{cls}\0{_skeleton(text)[0]}"
        return f"{cls}\0"

    def check(self, expected: str, actual: str) -> Optional[str]:
        """None when ``actual`` is acceptable for ``expected``; otherwise why not."""
        if self.kind in ("exact",):
            return None if expected == actual else "differs"
        if self.kind == "ignore":
            return None
        if self.kind == "pattern":
            assert self.pattern is not None
            return None if re.fullmatch(self.pattern, actual) else f"does not match /{self.pattern}/"
        skel_e, nums_e = _skeleton(expected)
        skel_a, nums_a = _skeleton(actual)
        if skel_e != skel_a:
            return "text around the numbers differs"
        for e, a in zip(nums_e, nums_a):
            limit = abs(e) * self.tolerance / 100.0 if self.relative else self.tolerance
            if abs(a - e) > limit + 1e-12:
                return f"{a:g} is {abs(a - e):g} from {e:g} (tolerance {self.tolerance:g}" \
                       f"{'%' if self.relative else ''})"
        return None


def parse_rule(text: str) -> Rule:
    """``exact``, ``ignore``, ``pattern:REGEX`` or ``tolerance:N`` / ``tolerance:N%``."""
    kind, _, arg = text.partition(":")
    kind = kind.strip().lower()
    if kind in ("exact", "ignore"):
        if arg:
            raise ValueError(f"rule {kind!r} takes no argument (got {text!r})")
        return Rule(kind)
    if kind == "pattern":
        try:
            re.compile(arg)
        except re.error as exc:
            raise ValueError(f"bad pattern in rule {text!r}: {exc}") from None
        return Rule("pattern", pattern=arg)
    if kind == "tolerance":
        rel = arg.endswith("%")
        try:
            tol = float(arg[:-1] if rel else arg)
        except ValueError:
            raise ValueError(f"tolerance needs a number, e.g. tolerance:0.05 or tolerance:2%; got {text!r}") \
                from None
        if tol < 0:
            raise ValueError(f"tolerance cannot be negative: {text!r}")
        return Rule("tolerance", tolerance=tol, relative=rel)
    raise ValueError(f"unknown rule {text!r}: use exact, ignore, pattern:REGEX or tolerance:N")


def parse_rule_option(text: str) -> List[Tuple[str, Rule]]:
    """``CLASS=RULE`` from the command line; aliases (``data``) expand to several classes."""
    cls, sep, rule = text.partition("=")
    if not sep or not cls.strip():
        raise ValueError(f"--rule wants CLASS=RULE (e.g. vin=tolerance:0.05), got {text!r}")
    parsed = parse_rule(rule)
    return [(c, parsed) for c in CLASS_ALIASES.get(cls.strip(), (cls.strip(),))]


@dataclass
class RuleSet:
    """Rules per event class; ``default`` for classes without their own, and a timing
    tolerance in HAT milliseconds (None: times are not compared)."""

    rules: Dict[str, Rule] = field(default_factory=dict)
    default: Rule = field(default_factory=lambda: Rule("exact"))
    timing_ms: Optional[float] = None

    def rule_for(self, cls: str) -> Rule:
        return self.rules.get(cls, self.default)

    def set(self, option: str) -> None:
        for cls, rule in parse_rule_option(option):
            if cls in ("*", "default"):
                self.default = rule
            else:
                self.rules[cls] = rule

    @classmethod
    def from_options(cls, options: Iterable[str], timing_ms: Optional[float] = None) -> RuleSet:
        rs = cls(timing_ms=timing_ms)
        for opt in options:
            rs.set(opt)
        return rs

    def describe(self) -> str:
        parts = [f"{c}={r}" for c, r in sorted(self.rules.items())] + [f"default={self.default}"]
        if self.timing_ms is not None:
            parts.append(f"timing=±{self.timing_ms:g} ms")
        return ", ".join(parts)


@dataclass(frozen=True)
class Unit:
    """One output line as compared: ``t`` is when its CRLF arrived (ms from script start)."""

    t: float
    text: str
    partial: bool = False   # the stream ended before a CRLF (e.g. a final prompt)
    cls: str = ""
    after: Optional[Tuple[float, bytes]] = None   # the host event before it: (t, bytes)
    host_index: Optional[int] = None              # the host line it answers (output_units)


def output_units(events: Iterable[dict], since: float = 0.0) -> List[Unit]:
    """The HAT's output from ``since`` on, as lines; partials join the line they begin.

    Each line's ``host_index`` is the host line it answers: the HAT ends every host line with a
    CRLF of its own (the blank line, or the echo when echo is on, FIRMWARE-BEHAVIOUR.md#fb-cr) before that
    line's answer, so the n-th such line starts the answer to the n-th host line. Counting the host
    lines *sent* instead would tie an answer to whatever the host had typed by the time it
    arrived, which differs between a recording and a replay on a loaded machine."""
    units: List[Unit] = []
    pending = bytearray()
    pending_t = 0.0
    after: Optional[Tuple[float, bytes]] = None
    typing = bytearray()            # host bytes since its last CR
    echoes: List[bytes] = []        # what ends each host line sent: its echo (or nothing)
    answered = 0                    # host lines whose ending CRLF has come
    for ev in events:
        if ev.get("dir") == "host":
            data = field_bytes(ev, "bytes")
            after = (float(ev.get("t", 0)), data)
            *ended, rest = data.split(b"\r")
            for line in ended:
                echoes.append(expected_echo(bytes(typing) + line))
                typing.clear()
            typing += rest
        if ev.get("dir") != "hat" or float(ev.get("t", 0)) < since:
            continue
        t = float(ev.get("t", 0))
        if "partial" in ev:
            if not pending:
                pending_t = t
            pending += field_bytes(ev, "partial")
        elif "line" in ev:
            data = bytes(pending) + field_bytes(ev, "line")
            pending.clear()
            text = data.decode("utf-8", errors="replace")
            if answered < len(echoes) and _PROMPTS.sub("", text).encode("utf-8", errors="replace") in (
                    b"", echoes[answered]):
                answered += 1
            units.append(Unit(t, text, after=after, host_index=answered))
    if pending:
        units.append(Unit(pending_t, bytes(pending).decode("utf-8", errors="replace"), partial=True,
                          after=after, host_index=answered))
    return units


def units_from_stream(chunks: Sequence[Tuple[float, bytes]]) -> List[Unit]:
    """Lines of a received byte stream given as (t, chunk) pairs."""
    units: List[Unit] = []
    pending = bytearray()
    for t, chunk in chunks:
        pending += chunk
        while True:
            i = pending.find(CRLF)
            if i < 0:
                break
            units.append(Unit(t, bytes(pending[:i]).decode("utf-8", errors="replace")))
            del pending[: i + 2]
    if pending:
        units.append(Unit(chunks[-1][0], bytes(pending).decode("utf-8", errors="replace"), partial=True))
    return units


_PROMPTS = re.compile(r"^(?:P[0-3]>|BHBL> )+")


def default_classifier() -> Callable[[str], str]:
    """The session's line classifier (harness/events.py), as ``text -> class``. A line that
    begins with prompts (they join the echo that follows) is classified by what follows
    them; prompts alone are ``prompt``."""
    from ..harness.events import classify as _classify  # late: compare's rules do not need the session

    def classify(text: str) -> str:
        rest = _PROMPTS.sub("", text)
        if rest != text and not rest:
            return "prompt"
        return _classify(rest).kind

    return classify


@dataclass(frozen=True)
class Difference:
    kind: str                   # missing | extra | changed | timing
    expected: Optional[Unit]
    actual: Optional[Unit]
    reason: str = ""


@dataclass
class Comparison:
    ops: List[Tuple[str, Optional[Unit], Optional[Unit], str]]   # (op, expected, actual, reason)
    rules: RuleSet
    ignored: Dict[str, int] = field(default_factory=dict)

    @property
    def differences(self) -> List[Difference]:
        return [Difference(op, e, a, why) for op, e, a, why in self.ops if op != "equal"]

    @property
    def ok(self) -> bool:
        return not self.differences

    @property
    def compared(self) -> int:
        return sum(1 for op, *_ in self.ops if op in ("equal", "changed", "timing"))

    def summary(self) -> str:
        d = self.differences
        counts = {k: sum(1 for x in d if x.kind == k) for k in ("missing", "extra", "changed", "timing")}
        ign = sum(self.ignored.values())
        head = "MATCH" if not d else "DIFFER"
        detail = ", ".join(f"{n} {k}" for k, n in counts.items() if n)
        extra = f"; {ign} line(s) ignored by rule" if ign else ""
        return f"{head}: {self.compared} line(s) compared{', ' + detail if detail else ''}{extra}"

    def render(self, host_events: Sequence[dict] = (), context: int = 2) -> str:
        """A line-oriented diff: ``-`` recorded, ``+`` received, ``!`` timing, with context."""
        show = [i for i, op in enumerate(self.ops) if op[0] != "equal"]
        if not show:
            return self.summary()
        keep = set()
        for i in show:
            keep.update(range(max(0, i - context), min(len(self.ops), i + context + 1)))
        hunks: List[List[int]] = []
        for i in sorted(keep):
            if hunks and i == hunks[-1][-1] + 1:
                hunks[-1].append(i)
            else:
                hunks.append([i])
        out: List[str] = []
        for hunk in hunks:
            first = next(i for i in hunk if self.ops[i][0] != "equal")
            out.append(self._hunk_header(self.ops[first][1], self.ops[first][2], host_events))
            for i in hunk:
                out.extend(self._op_lines(*self.ops[i]))
        out.append(self.summary())
        return "\n".join(out)

    def _op_lines(self, op: str, e: Optional[Unit], a: Optional[Unit], why: str) -> List[str]:
        if op == "equal" and e is not None:
            return [f"  {_show(e.text)}"]
        if op == "missing" and e is not None:
            return [f"- {_show(e.text)}    [{e.cls}: not received, t={e.t:g} ms]"]
        if op == "extra" and a is not None:
            return [f"+ {_show(a.text)}    [{a.cls}: not in the recording, t={a.t:g} ms]"]
        if op == "changed" and e is not None and a is not None:
            rule = self.rules.rule_for(e.cls)
            return [f"- {_show(e.text)}", f"+ {_show(a.text)}    [{e.cls}: {rule}: {why}]"]
        return [f"! {_show(e.text if e else '')}    [{why}]"]

    @staticmethod
    def _hunk_header(e: Optional[Unit], a: Optional[Unit], host_events: Sequence[dict]) -> str:
        u = e if e is not None else a
        t = u.t if u is not None else 0.0
        after = u.after if u is not None else None
        if after is None:   # units built without host context: the last host event by time
            last = [h for h in host_events if float(h.get("t", 0)) <= t]
            after = (float(last[-1]["t"]), field_bytes(last[-1], "bytes")) if last else None
        where = f", after host {after[1]!r} at t={after[0]:g} ms" if after else ""
        return f"@@ t={t:g} ms{where} @@"


def _show(text: str) -> str:
    """Printable form of a line: control bytes escaped so the diff stays one line each."""
    return "".join(c if c.isprintable() or c == " " else f"\\x{ord(c):02X}" for c in text)


def compare_units(expected: Sequence[Unit], actual: Sequence[Unit], rules: RuleSet,
                  classify: Optional[Callable[[str], str]] = None) -> Comparison:
    """Align and compare two output-line sequences under ``rules``."""
    classify = classify or default_classifier()
    ignored: Dict[str, int] = {}

    def prepare(units: Sequence[Unit]) -> List[Unit]:
        kept = []
        for u in units:
            cls = u.cls or classify(u.text)
            if rules.rule_for(cls).kind == "ignore":
                ignored[cls] = ignored.get(cls, 0) + 1
                continue
            kept.append(Unit(u.t, u.text, u.partial, cls, u.after, u.host_index))
        return kept

    exp, act = prepare(expected), prepare(actual)

    def key(u: Unit) -> str:
        # An answer belongs to the host line that caused it: anchoring it there keeps identical
        # lines (blank, Error) from being paired across commands. Asynchronous lines may fall on
        # either side of a host line on a real-time target, so they float.
        anchor = "" if u.host_index is None or u.cls in ASYNC_CLASSES else f"{u.host_index}\0"
        return anchor + rules.rule_for(u.cls).key(u.cls, u.text)

    keys_e = [key(u) for u in exp]
    keys_a = [key(u) for u in act]
    ops: List[Tuple[str, Optional[Unit], Optional[Unit], str]] = []
    matcher = difflib.SequenceMatcher(None, keys_e, keys_a, autojunk=False)
    for tag, i1, i2, j1, j2 in matcher.get_opcodes():
        if tag == "equal" or tag == "replace":
            n = min(i2 - i1, j2 - j1)
            for k in range(n):
                ops.append(_pair(exp[i1 + k], act[j1 + k], rules))
            ops.extend(("missing", u, None, "") for u in exp[i1 + n:i2])
            ops.extend(("extra", None, u, "") for u in act[j1 + n:j2])
        elif tag == "delete":
            ops.extend(("missing", u, None, "") for u in exp[i1:i2])
        else:
            ops.extend(("extra", None, u, "") for u in act[j1:j2])
    return Comparison(ops, rules, ignored)


def _pair(e: Unit, a: Unit, rules: RuleSet) -> Tuple[str, Optional[Unit], Optional[Unit], str]:
    why = rules.rule_for(e.cls).check(e.text, a.text)
    if why is not None:
        return ("changed", e, a, why)
    if rules.timing_ms is not None and abs(a.t - e.t) > rules.timing_ms:
        return ("timing", e, a, f"at t={a.t:g} ms, recorded t={e.t:g} ms (tolerance ±{rules.timing_ms:g} ms)")
    return ("equal", e, a, "")
