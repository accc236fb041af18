"""What a failure was, in the terms a firmware engineer thinks in: the line the case sent, the
lines it expected, the lines the HAT sent back, and the first line where the two differ.

Everything here is read from the JUnit file and the case's transcript, never from the test
code: the one-line failure message (or pytest's ``E`` lines for an ``assert got == expected``),
and, in the transcript, the test's own commands (the suite's clean-up before the case and its
``version`` fences after each command are left out).
"""
from __future__ import annotations

import ast
import difflib
import os
import re
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

from ...harness.transcript import field_bytes, iter_events
from ..mismatch import EXPECTED_REPLY, RECEIVED_REPLY
from .junit import Case, JunitRun

__all__ = ["MODULE_PATH", "NOTHING", "scrub", "Exchange", "headline", "exchange_of", "FailureGroup",
           "group_failures", "skip_reasons", "Change", "changes_since"]

# The parameter ``hat`` shown by pytest as the failing line's context: a repr, never a reason.
_REPR = re.compile(r"<[\w.]+ object at 0x[0-9a-fA-F]+>")
# An exception's module path in front of its name says nothing to a firmware engineer.
MODULE_PATH = re.compile(r"^(?:[a-z_]\w*\.)+(?=[A-Z]\w*: )")
# "... got '<line>'" in an oracle's reason: the received line that is wrong.
_GOT = re.compile(r"\bgot (?P<q>['\"])(?P<line>.*?)(?P=q)(?:$|[,;)]|\s)")
# ... and in the suite's own voice (conformance/mismatch.py): "...; came `<line>`".
_CAME = re.compile(r"\bcame `(?P<line>[^`]*)`")
_FENCE = "version"
NOTHING = "(nothing)"


def scrub(text: str) -> str:
    """Text from pytest with its object reprs (``hat = <...Hat object at 0x...>``) shortened:
    an address says nothing to a reader and changes from run to run."""
    return _REPR.sub("<…>", text)


def headline(case: Case) -> str:
    """The first line that says something: the message unless it is only pytest's context
    (``hat = <...Hat object at 0x...>``, a source line), else the first ``E`` line."""
    msg = case.message.strip().splitlines()[0] if case.message.strip() else ""
    if msg and not _REPR.search(msg):
        return MODULE_PATH.sub("", msg)
    for line in case.detail.splitlines():
        if line.startswith("E "):
            text = line[1:].strip()
            if text and not _REPR.search(text):
                return MODULE_PATH.sub("", re.sub(r"^(AssertionError|Failed): ", "", text))
    return _REPR.sub("<…>", msg) or "(no message)"


def _assert_reason(detail: str) -> str:
    """An ``assert`` that is not one string comparison, in one line: the statement from the
    test's source, then pytest's explanation of its values (reprs of objects left out)."""
    source = next((ln[1:].strip() for ln in detail.splitlines() if ln.startswith(">") and "assert" in ln), "")
    explained = " ".join(ln[1:].strip() for ln in detail.splitlines() if ln.startswith("E "))
    explained = re.sub(r"^AssertionError: ", "", _REPR.sub("…", explained))
    explained = re.sub(r"<built-in method (\w+) of \w+ object at 0x[0-9a-fA-F]+>", r"\1", explained)
    explained = re.sub(r"\s+", " ", explained)
    text = f"{source} — {explained}" if source and explained else source or explained
    return text[:300] + ("…" if len(text) > 300 else "")


def _lines(value: object) -> List[str]:
    """A literal from an assertion as lines, the way the HAT's CRLF-ended lines read."""
    text = value.decode("latin-1") if isinstance(value, bytes) else str(value)
    parts = text.replace("\r\n", "\n").split("\n")
    if len(parts) > 1 and parts[-1] == "":
        parts.pop()      # a final CRLF ends the last line; it does not start another
    return parts


def _assertion(detail: str) -> Optional[Tuple[List[str], List[str]]]:
    """(received, expected) lines from pytest's ``assert <got> == <expected>``; pytest's
    ``-``/``+`` diff lines replace literals it shortened with ``...``."""
    e_lines = [ln[1:].strip() for ln in detail.splitlines() if ln.startswith("E ")]
    for i, line in enumerate(e_lines):
        m = re.search(r"\bassert (.*)$", line)
        if not m:
            continue
        expr = m.group(1).strip()
        while expr.startswith("(") and not _parses(expr):
            expr = expr[1:]
        while expr.endswith(")") and not _parses(expr):
            expr = expr[:-1]
        try:
            node = ast.parse(expr, mode="eval").body
        except SyntaxError:
            continue
        if not (isinstance(node, ast.Compare) and len(node.ops) == 1 and isinstance(node.ops[0], ast.Eq)):
            continue
        try:
            got = ast.literal_eval(node.left)
            want = ast.literal_eval(node.comparators[0])
        except ValueError:
            continue
        if not isinstance(got, (str, bytes)) or not isinstance(want, (str, bytes)):
            continue
        got_l, want_l = _lines(got), _lines(want)
        rest = e_lines[i + 1:]
        minus = [ln[2:] for ln in rest if ln.startswith("- ")]
        plus = [ln[2:] for ln in rest if ln.startswith("+ ")]
        if m.group(1).startswith("(") and rest:     # pytest's wrapping "(" ends after the diff
            last = rest[-1]
            if last.startswith(("- ", "+ ")) and last.endswith(")"):
                minus = minus[:-1] + [minus[-1][:-1]] if last.startswith("- ") and minus else minus
                plus = plus[:-1] + [plus[-1][:-1]] if last.startswith("+ ") and plus else plus
        if "..." in repr(got) and plus:
            got_l = plus
        if "..." in repr(want) and minus:
            want_l = minus
        if got_l == want_l:
            continue      # one equal part of a longer expression (``a == b and c == d``)
        return got_l, want_l
    return None


def _stated(detail: str) -> Optional[Tuple[List[str], List[str]]]:
    """(received, expected) lines from a suite-voiced failure (conformance/mismatch.py), which
    states both replies whole, each on a line of its own after its label."""
    found: Dict[str, object] = {}
    for raw in detail.splitlines():
        line = raw[1:].strip() if raw.startswith("E ") else raw.strip()
        for label in (EXPECTED_REPLY, RECEIVED_REPLY):
            if line.startswith(label):
                try:
                    found[label] = ast.literal_eval(line[len(label):])
                except (ValueError, SyntaxError):
                    pass
    want, got = found.get(EXPECTED_REPLY), found.get(RECEIVED_REPLY)
    if isinstance(want, bytes) and isinstance(got, bytes):
        return _lines(got), _lines(want)
    return None


def _parses(expr: str) -> bool:
    try:
        ast.parse(expr, mode="eval")
    except SyntaxError:
        return False
    return True


@dataclass
class Exchange:
    """One failing case, as the wire saw it."""

    why: str                                     # the headline
    sent: str = ""                               # the test's command that failed (best guess)
    reply: List[str] = field(default_factory=list)       # what the HAT printed after it
    expected: Optional[List[str]] = None          # from the assertion, when it has one
    received: Optional[List[str]] = None
    first_expected: str = ""                      # the first differing line, each side
    first_received: str = ""
    mark: int = -1                                # the index in ``reply`` of the line that is wrong

    @property
    def key(self) -> str:
        """The group a failure belongs to: its first differing line, or its reason with the
        numbers and quoted words that vary between cases taken out."""
        if self.expected is not None:
            return f"expected {_show(self.first_expected)} · received {_show(self.first_received)}"
        text = re.sub(r"`[^`]*`|'[^']*'|\"[^\"]*\"", "…", self.why)
        return re.sub(r"\b\d+(\.\d+)?\b", "N", text)[:160]


def _show(line: str) -> str:
    if line == NOTHING:
        return NOTHING
    return f"“{line}”" if line else "an empty line"


def _first_difference(expected: List[str], received: List[str]) -> Tuple[str, str]:
    sm = difflib.SequenceMatcher(a=expected, b=received, autojunk=False)
    for tag, i1, i2, j1, j2 in sm.get_opcodes():
        if tag != "equal":
            return (expected[i1] if i1 < i2 else NOTHING), (received[j1] if j1 < j2 else NOTHING)
    return NOTHING, NOTHING


def _host_lines(ev: dict) -> List[str]:
    """The lines of one host write (the link may write several at once, each ended by CR)."""
    parts = field_bytes(ev, "bytes").decode("latin-1").split("\r")
    if len(parts) > 1 and parts[-1] == "":
        parts.pop()
    return [p.strip("\n") for p in parts]


def _is_fence(line: str) -> bool:
    """``version`` as the line's last command; the link's resynchronising fence carries a
    marker after a NUL (``echo 0 ; version\\0sync-...``)."""
    last = line.split(";")[-1].strip()
    return last == _FENCE or last.startswith(_FENCE + "\0")


def _commands(path: str) -> List[Tuple[str, List[str]]]:
    """The test's own commands with the lines the HAT printed after each. The clean-up before
    the case ends with the first fence. A fence (``version`` sent right after a command) is
    written before the command's reply arrives: the reply runs on until the fence's answer,
    whose own empty line (the fence's CR) is not the command's."""
    out: List[Tuple[str, List[str]]] = []
    started = False
    fenced = False           # a fence was sent and its answer has not come yet
    after_fence = False      # the last host line was a fence (or nothing yet)
    for ev in iter_events(path):
        kind = ev.get("dir")
        if kind == "host":
            for cmd in _host_lines(ev):
                # A version right after a command is a fence; one after a fence is the test's own.
                is_fence = _is_fence(cmd) and (not started or (not after_fence and bool(out)))
                if is_fence:
                    fenced = started
                    started = True
                    after_fence = True
                    continue
                if started and cmd:
                    out.append((cmd, []))
                    fenced = False
                    after_fence = False
        elif kind == "hat" and out:
            line = ev.get("line", ev.get("partial", ""))
            if fenced and line.startswith("Firmware version: "):
                if out[-1][1] and out[-1][1][-1] == "":
                    out[-1][1].pop()
                fenced = False
                continue
            if fenced or not after_fence:
                out[-1][1].append(line)
    return out


def exchange_of(case: Case) -> Exchange:
    ex = Exchange(why=headline(case))
    parsed = _stated(case.detail) or _stated(case.message) or _assertion(case.detail)
    if parsed:
        ex.received, ex.expected = parsed
        ex.first_expected, ex.first_received = _first_difference(ex.expected, ex.received)
        if ex.why.startswith(("assert ", "assert(")):
            ex.why = ex.key      # the assertion's own text says less than its two sides
    elif ex.why.startswith(("assert ", "assert(")):
        ex.why = _assert_reason(case.detail) or ex.why
    if case.transcript and os.path.isfile(case.transcript):
        try:
            commands = _commands(case.transcript)
        except (OSError, ValueError):
            commands = []
        if commands:
            pick = commands[-1]
            # The command whose reply holds the received line that differs, if one does.
            probe = ex.first_received if ex.first_received not in ("", NOTHING) else ""
            words = set(re.findall(r"[\w?]+", ex.why))
            quoted = _quoted(ex.why)
            if probe:
                pick = next((c for c in reversed(commands) if probe in c[1]), pick)
            elif quoted:
                pick = next((c for c in reversed(commands) if quoted[0] in c[1]), pick)
            elif words:
                # A reason that names the command ("pid takes 10 parameters"): the last one sent.
                pick = next((c for c in reversed(commands) if c[0].split()[0] in words), pick)
            ex.sent, ex.reply = pick[0], pick[1]
            ex.mark = _wrong_line(ex)
    return ex


def _quoted(why: str) -> List[str]:
    """The received lines a reason quotes as wrong (an oracle's ``got '…'``, the suite's ``came `…```)."""
    return [m.group("line") for m in _GOT.finditer(why)] + [m.group("line") for m in _CAME.finditer(why)]


def _wrong_line(ex: Exchange) -> int:
    """Where in the reply the wrong line is: the assertion's first differing received line, or
    the line an oracle's reason quotes after ``got``."""
    wanted = [ex.first_received] if ex.first_received not in ("", NOTHING) else []
    wanted += _quoted(ex.why)
    for want in wanted:
        for i, line in enumerate(ex.reply):
            if line == want:
                return i
        for i, line in enumerate(ex.reply):
            if want.strip() and want.strip() in line:
                return i
    # A reason that names a whole reply line in backquotes (`P0: pulse done` 16 ms after ...).
    for want in re.findall(r"`([^`]+)`", ex.why):
        if want in ex.reply:
            return ex.reply.index(want)
    return -1


@dataclass
class FailureGroup:
    key: str
    members: List[Tuple[JunitRun, Case, Exchange]]

    @property
    def requirements(self) -> List[str]:
        return sorted({r for _run, c, _ex in self.members for r in c.requirements})

    @property
    def example(self) -> Tuple[JunitRun, Case, Exchange]:
        return self.members[0]


def group_failures(items: Sequence[Tuple[JunitRun, Case]]) -> List[FailureGroup]:
    """Failures grouped by their first differing line (or normalised reason), largest first."""
    groups: Dict[str, FailureGroup] = {}
    for run, case in items:
        ex = exchange_of(case)
        groups.setdefault(ex.key, FailureGroup(ex.key, [])).members.append((run, case, ex))
    return sorted(groups.values(), key=lambda g: -len(g.members))


def skip_reasons(items: Sequence[Tuple[JunitRun, Case]]) -> List[Tuple[str, List[Case]]]:
    """Skip messages (what the case needs connected or controllable), most frequent first."""
    out: Dict[str, List[Case]] = {}
    for _run, case in items:
        reason = (case.message or case.detail or "no reason given").strip().splitlines()[0]
        reason = re.sub(r"^Skipped: ", "", reason)
        out.setdefault(reason, []).append(case)
    return sorted(out.items(), key=lambda kv: -len(kv[1]))


@dataclass
class Change:
    test_id: str
    before: str
    after: str


def changes_since(previous: JunitRun, current: JunitRun) -> List[Change]:
    """Cases whose verdict differs from the previous run of the same target (new cases count
    as changed from ``new``; cases that are gone as changed to ``gone``)."""
    before = {c.test_id: c.verdict for c in previous.cases}
    after = {c.test_id: c.verdict for c in current.cases}
    out = [Change(t, before.get(t, "new"), v) for t, v in after.items() if before.get(t) != v]
    out += [Change(t, v, "gone") for t, v in before.items() if t not in after]
    return out
