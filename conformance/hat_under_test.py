"""The suite's view of a HAT: one :class:`HatUnderTest` around the harness Session.

It adds what conformance checks need on top of the Session: the exact bytes a line produced
(``exchange``), HAT-time waits and collection scaled by the target's time scale, the PID
command in the profile's own syntax, and the cleanup fence run between test cases.
"""
from __future__ import annotations

import re
from typing import Any, Callable, List, Optional, Union

from ..harness.errors import ExpectTimeout, NeedsCapability, TargetError
from ..harness.matching import matcher
from ..protocol.profiles import Profile, neighbours
from .reply import ASYNC_BYTES, ASYNC_LINE, Reply, without_fence_line
from .resync import Resync
from .target_fault import TargetFault, target_fault_of
from .verdict import UnknownBuild

__all__ = ["HatUnderTest", "Reply", "TargetGone", "TargetFault", "ASYNC_BYTES", "ASYNC_LINE"]

FENCE_ANSWER = b"Firmware version: "
_TABLES = ("commands", "set_keywords", "help_lines")     # Profile fields, not features
#: How long the fence's line ending may lag a version line before the count is taken as off. The
#: HAT prints a line's CRLF before its answer and the next line's CRLF right after it; this is
#: many times the gap a loaded host or a slow link puts between them.
GRACE_S = 1.0

class TargetGone(RuntimeError):
    """The target stopped answering (closed, killed, unplugged)."""


def _index_of(events: List[Any], event: Any, start: int) -> int:
    for i in range(len(events) - 1, start - 1, -1):
        if events[i] is event:
            return i
    return start


class HatUnderTest(Resync):
    def __init__(self, session: Any, target: Any, url: str):
        self.session = session
        self.target = target
        self.url = url
        self._next = 0                  # first event not yet handed to the test
        self._fence_own: set[int] = set()   # events of fences that ended a collection window
        self._init_resync()

    # -- identity ----------------------------------------------------------------------
    @property
    def profile(self) -> Profile:
        return self.session.profile

    @property
    def profile_exact(self) -> bool:
        return bool(getattr(self.session, "profile_exact", True))

    @property
    def profile_why(self) -> str:
        """How the profile was chosen when the target's version did not name it (one line), else ""."""
        return str(getattr(self.session, "profile_why", "") or "")

    @property
    def profile_label(self) -> str:
        """The profile's name as the report shows it: ``R7``, ``R7 (nearest earlier)`` or, for a
        version line with no readable number, ``R7 (version unreadable)``."""
        if self.profile_exact:
            return self.profile.name
        head = str(getattr(self.session, "version_string", "") or "").split()[:1]
        basis = "nearest earlier" if head and head[0].isdigit() else "version unreadable"
        return f"{self.profile.name} ({basis})"

    @property
    def between(self) -> Optional[tuple[Profile, Profile]]:
        """For an unknown build between two known releases (the session detected it, it was not
        forced with ``--firmware``): those two releases; else None."""
        if self.profile_exact:
            return None
        head = str(getattr(self.session, "version_string", "") or "").split()[:1]
        return neighbours(int(head[0])) if head and head[0].isdigit() else None

    def undecided(self, key: str) -> Optional[str]:
        """Why ``key`` is unknown for this build (its neighbouring releases differ on it), or None
        when the profile's value holds. ``key``: a feature of profiles.json, or one of the
        tables ``commands``, ``set_keywords``, ``help_lines``."""
        pair = self.between
        if pair is None:
            return None
        a, b = pair
        table = key in _TABLES
        va, vb = (getattr(a, key), getattr(b, key)) if table else (a.features.get(key), b.features.get(key))
        if va == vb:
            return None
        what = f"their {key} differ" if table else f"{key} is {va!r} on {a.name}, {vb!r} on {b.name}"
        build = self.session.version_string.split()[0]
        return f"behaviour of {a.name} or {b.name}: unknown build {build} ({what})"

    def _decided(self, key: str) -> None:
        why = self.undecided(key)
        if why is not None:
            raise UnknownBuild(why)

    def feature(self, key: str) -> Any:
        """The release's value of ``key``; for an unknown build whose neighbouring releases
        differ on it, :class:`UnknownBuild` (the case is then informational, never failed)."""
        self._decided(key)
        return self.profile.features[key]

    def has(self, command: str) -> bool:
        """Whether the release has ``command`` (UnknownBuild when only one neighbour has it)."""
        pair = self.between
        if pair is not None and (command in pair[0].commands) != (command in pair[1].commands):
            raise UnknownBuild(f"behaviour of {pair[0].name} or {pair[1].name}: unknown build "
                               f"{self.session.version_string.split()[0]} (only one of them has `{command}`)")
        return command in self.profile.commands

    # The release's tables, decided as features are: an unknown build between releases whose
    # tables differ cannot be held to either.
    @property
    def commands(self) -> tuple:
        self._decided("commands")
        return self.profile.commands

    @property
    def set_keywords(self) -> tuple:
        self._decided("set_keywords")
        return self.profile.set_keywords

    @property
    def help_bytes(self) -> bytes:
        self._decided("help_lines")
        return self.profile.help_bytes

    @property
    def time_scale(self) -> float:
        return float(getattr(self.session, "time_scale", 1.0) or 1.0)

    def seconds(self, hat_ms: float) -> float:
        """Seconds on :meth:`clock` for a stretch of HAT time."""
        return hat_ms / 1000.0 / self.time_scale

    def clock(self) -> float:
        """The session's clock in seconds: the wall clock, or HAT time for a virtual-time
        target (every wait and deadline here uses it, so such a run never sleeps)."""
        return self.session.clock()

    def can(self, capability: str) -> bool:
        return bool(self.target.has(capability))

    # -- traffic -----------------------------------------------------------------------
    def send(self, text: Union[str, bytes]) -> None:
        """One host line: text + CR (never CRLF). Bytes are sent exactly as given."""
        if isinstance(text, bytes):
            self.session.send_raw(text)
        else:
            self.session.send(text)

    def exchange(self, text: Union[str, bytes], timeout_ms: float = 2000) -> Reply:
        """Send a line (str: CR added; bytes: exactly these) and return what it produced.

        A ``version`` line follows as the fence; its answer (and, with echo on, its echo and
        prompt) is cut off the reply.
        """
        # Start at the beginning of any line still arriving (a PID line half received), so
        # the reply holds whole lines and that line can be recognised as asynchronous.
        lock = getattr(self.session, "_cond", None)
        if lock is not None:
            with lock:
                mark = len(self.session.received) - len(self.session.partial)
        else:
            mark = len(self.session.received) - len(self.session.partial)
        first_event = self.session.mark()
        data = text if isinstance(text, bytes) else text.encode("latin-1") + b"\r"
        self.send(data)
        boundary, self._next = self.fence(max(2.0, self.seconds(timeout_ms)))
        raw = bytes(self.session.received[mark:])
        cut = raw.rfind(FENCE_ANSWER)
        if cut >= 0:
            # The fence line's own CR gives CRLF first; with echo on "version" is echoed before it
            # (a stream's line may sit among those bytes: reply.py).
            raw = without_fence_line(raw[:cut])
        return Reply(data, raw, list(self.session.events[first_event:boundary]))

    def fence(self, timeout: float, between_cases: bool = False) -> tuple[int, int]:
        """Send ``version`` and wait for *its* answer: the first version line after the CRLF
        of the fence's own line (a version line the test's own line printed does not count).
        Returns (index of the fence's first event, index just after its answer).

        Counting CRLFs is fast and exact on a sound link; when it finds no answer (a line ending
        lost or added on the link, a silent or restarted HAT) the link is resynchronised by
        content and the case ends with a :class:`TargetFault` saying what the target did.
        ``between_cases`` (the set-up's fence, resync.py): ExpectTimeout is raised instead, and
        a restart is left to the set-up."""
        s = self.session
        start, start_byte = s.mark(), len(s.received)
        try:
            line_no = s.send("version")

            def own_line_ending(e: Any) -> bool:
                """the CRLF (or echo) of the fence's own line"""
                return e.fields.get("host_line") == line_no

            def version_line(e: Any) -> bool:
                """the `Firmware version:` line answering the fence"""
                return e.kind == "version"

            def ending_or_answer(e: Any) -> bool:
                """the fence's own line ending, or a version line before it"""
                return own_line_ending(e) or version_line(e)

            crlf = s.expect(ending_or_answer, timeout=timeout, since=start)
            if not own_line_ending(crlf):
                # A version line came first: the answer to a `version` of the test's own (then
                # the fence's line ending follows at once), or the fence's answer with its line
                # ending lost on the link (then it never comes: find our place by content now
                # rather than at the timeout).
                crlf = s.expect(own_line_ending, timeout=min(timeout, GRACE_S),
                                since=_index_of(s.events, crlf, start) + 1)
            boundary = _index_of(s.events, crlf, start)
            answer = s.expect(version_line, timeout=timeout, since=boundary + 1)
        except ExpectTimeout:
            if between_cases:
                raise
            raise self._recover(start, start_byte, timeout) from None
        except TargetError as exc:
            raise target_fault_of(exc) from None
        after = _index_of(s.events, answer, boundary) + 1
        if crlf.kind == "echo":
            # With echo on the prompt follows the answer; take it now so it does not open the
            # next reply.
            try:
                prompt = s.expect("prompt", timeout=min(timeout, 0.5), since=after)
                after = _index_of(s.events, prompt, after) + 1
            except AssertionError:
                pass
        if not between_cases:
            self.check_reboot(after)
        return boundary, after

    def setup(self, line: str, timeout_ms: float = 2000) -> List[Reply]:
        """A set-up line of the suite's own (``port 1 ; select 3 ; ...``): sent whole once the
        ``;`` separator has passed its check, else one command per line
        (conformance/trusted_clauses.py). One reply per line sent."""
        return [self.exchange(part, timeout_ms) for part in self.clauses.split(line)]

    def exchange_quiet(self, text: Union[str, bytes], attempts: int = 3) -> Reply:
        """``exchange``, repeated while asynchronous lines got mixed into the reply, so the
        reply can be compared byte for byte."""
        reply = self.exchange(text)
        for _ in range(attempts - 1):
            if not any(ASYNC_LINE.match(line) for line in reply.lines):
                break
            reply = self.exchange(text)
        return reply

    def lines(self, text: str) -> List[str]:
        return self.exchange(text).text_lines

    def _take(self) -> List[Any]:
        """Events not yet handed to the test (since the last reply or collection)."""
        events = self.session.events
        end = len(events)
        out = [e for i, e in enumerate(events[self._next:end], self._next) if i not in self._fence_own]
        self._next = end
        self._fence_own = {i for i in self._fence_own if i >= end}
        return out

    def collect_ms(self, hat_ms: float) -> List[Any]:
        """Every event since the last reply or collection, after waiting this much HAT time.
        The window ends with a fence, so whatever the HAT printed in it has arrived however
        slow the link (H10: a fixed 150 ms wall-clock floor did that job before, and cost
        most of a case's time at --speed 20)."""
        self._note_wait(hat_ms)          # H10: the window is mandatory waiting; the fence is not
        self.session.sleep(self.seconds(hat_ms))
        self._settle()
        return self._take()

    def _settle(self) -> None:
        """Fence: the HAT answers in order, so once its answer is in, nothing it printed
        before is still on its way. The fence's own line, answer and prompt are marked so that
        no collection hands them to a test."""
        boundary, after = self.fence(2.0)
        events = self.session.events
        self._fence_own.add(boundary)
        self._fence_own.update(i for i in range(boundary + 1, after)
                               if events[i].kind in ("version", "prompt"))

    def _note_wait(self, hat_ms: float) -> None:
        """H10 (make bench): count HAT time a test must wait (see Session.note_wait)."""
        note = getattr(self.session, "note_wait", None)
        if note is not None:
            note(hat_ms)

    def _await_new(self, seen: int, deadline: float) -> bool:
        """Block until there are more than ``seen`` events or the wall-clock deadline passes
        (woken by the event itself: H10, polling every 10 ms cost ~5 ms a wait)."""
        self.session.wait_ms(0)          # raises if the target has gone away
        left = deadline - self.clock()
        return left > 0 and self.session.wait_new(seen, left)

    def wait_for(self, predicate: Callable[[Any], bool], count: int, max_hat_ms: float) -> List[Any]:
        """Collect events until ``count`` of them satisfy ``predicate`` or ``max_hat_ms`` of
        HAT time is up (then a fence brings in what is still on its way); returns everything
        collected."""
        out: List[Any] = []
        began = self.clock()
        deadline = began + self.seconds(max_hat_ms)
        matched = 0
        while True:
            new = self._take()
            out += new
            matched += sum(1 for e in new if predicate(e))   # each event is judged once
            if matched >= count:
                break
            if self.clock() >= deadline:
                self._settle()
                out += self._take()
                break
            self._await_new(self._next, deadline)
        # H10: waiting for lines the HAT prints on its own schedule is mandatory waiting (at
        # most what the test allowed).
        self._note_wait(min(max_hat_ms, (self.clock() - began) * 1000.0 * self.time_scale))
        return out

    def _find(self, start: int, predicate: Callable[[Any], bool], deadline: float) -> Optional[int]:
        """Index of the first event from ``start`` on (fence events left out) that satisfies
        ``predicate``, waiting for new ones until the wall-clock deadline; None after it."""
        i = start
        while True:
            events = self.session.events
            while i < len(events):
                if i not in self._fence_own and predicate(events[i]):
                    return i
                i += 1
            if not self._await_new(i, deadline):
                return None

    def watch(self, mark: int, predicate: Callable[[Any], bool], hat_ms: float) -> bool:
        """Wait until an event from ``mark`` on satisfies ``predicate`` (True) or ``hat_ms`` of
        HAT time has passed (False). Nothing is consumed: the events stay for the test. The
        time spent counts as mandatory waiting (the HAT's own schedule)."""
        began = self.clock()
        try:
            return self._find(mark, predicate, began + self.seconds(hat_ms)) is not None
        finally:
            self._note_wait(min(hat_ms, (self.clock() - began) * 1000.0 * self.time_scale))

    def mark(self) -> int:
        """A position in the event stream, for :meth:`since`."""
        return len(self.session.events)

    def since(self, mark: int) -> List[Any]:
        """Every event from ``mark`` on, whatever replies and collections happened meanwhile."""
        return [e for i, e in enumerate(self.session.events[mark:], mark) if i not in self._fence_own]

    def wait_ms(self, hat_ms: float) -> None:
        self.session.wait_ms(hat_ms)

    def expect(self, match: Union[str, Callable[[Any], bool]], hat_ms: float) -> Any:
        """The first event (since the last reply or collection) matching ``match`` (an event
        kind, a regular expression searched in the text, or a predicate); events after it stay
        for the next collection. The deadline is HAT time; when it has passed, a fence brings in
        what is still on its way before the search gives up."""
        if callable(match):
            pred, what = matcher(match)
        else:
            rx = re.compile(match)
            pred = (lambda e: e.kind == match or bool(rx.search(e.text)))  # noqa: E731
            what = repr(match)
        began = self.clock()
        i = self._find(self._next, pred, began + self.seconds(hat_ms))
        if i is None:
            # Time is up: a fence brings in whatever the HAT printed before it; look once more.
            self._settle()
            i = self._find(self._next, pred, 0.0)
        if i is None:
            seen = [e.text for e in self.session.events[self._next:]][-15:]
            raise AssertionError(f"expected {what} within {hat_ms:g} ms of HAT time; "
                                 f"the last lines were {seen!r}")
        self._next = i + 1
        # H10: waiting for a line the HAT prints on its own schedule is mandatory.
        self._note_wait(min(hat_ms, (self.clock() - began) * 1000.0 * self.time_scale))
        return self.session.events[i]

    def world(self, line: str) -> str:
        if line.strip().lstrip("@").split(" ", 1)[0] == "reset":
            # A restart the test asked for is not a fault; the next resync sets up again.
            self._restart_asked = True
        try:
            return self.session.world(line)
        except NeedsCapability as exc:
            # A target that performs this action for some devices, not this one (rp2040: plugs passive
            # devices only): the case cannot be set up there, which says nothing about the protocol.
            import pytest
            pytest.skip(f"{exc} (target {self.url})")

    def now_ms(self) -> float:
        """Session time (ms since open), the clock of ``Event.t``."""
        events = self.session.events
        return events[-1].t if events else 0.0

    # -- commands in this profile's syntax -------------------------------------------------
    def pid_command(self, port: int, mode: int, offset: int, fmt: str, scale: str, unwrap: str,
                    kp: str, ki: str, kd: str, windup: str, deadzone: str = "0.01",
                    differentiate: bool = False) -> str:
        """``pid`` with the release's parameter count: 10 (R1-R5) or 11 with deadzone (R6+)."""
        name = "pid_diff" if differentiate else "pid"
        args = [port, mode, offset, fmt, scale, unwrap, kp, ki, kd, windup]
        if self.feature("pid_numbers") >= 11:
            args.append(deadzone)
        return " ".join([name] + [str(a) for a in args])
