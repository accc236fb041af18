"""The suite's view of a HAT: one :class:`Hat` around the harness Session.

It adds what conformance checks need on top of the Session: the exact bytes a line produced
(``exchange``), HAT-time waits and collection scaled by the target's time scale, the PID
command in the profile's own syntax, and the cleanup fence run between test cases.
"""
from __future__ import annotations

import re
from typing import Any, Callable, List, Optional, Union

from ..harness.errors import ExpectTimeout, TargetError
from ..harness.matching import matcher
from ..protocol.profiles import Profile
from .reply import ASYNC_BYTES, ASYNC_LINE, Reply
from .target_fault import DEAD, GARBLED, NOT_READING, REBOOTED, TargetFault, describe_silence

__all__ = ["Hat", "Reply", "TargetGone", "TargetFault", "ASYNC_BYTES", "ASYNC_LINE"]

FENCE_ANSWER = b"Firmware version: "

class TargetGone(RuntimeError):
    """The target stopped answering (closed, killed, unplugged)."""


def _index_of(events: List[Any], event: Any, start: int) -> int:
    for i in range(len(events) - 1, start - 1, -1):
        if events[i] is event:
            return i
    return start


class Hat:
    def __init__(self, session: Any, target: Any, url: str):
        self.session = session
        self.target = target
        self.url = url
        self._next = 0                  # first event not yet handed to the test
        self._powered_checked = False
        self._fence_own: set[int] = set()   # events of fences that ended a collection window
        #: Ports whose drive the fence leaves alone (devices that need power to stay connected).
        self.powered_ports: tuple[int, ...] = ()
        self._scanned = session.mark()  # events before this were looked at for a start-up banner
        self._case_bytes = 0            # byte offset where the current case's traffic began
        #: The HAT restarted; the next resync puts the suite's preconditions back.
        self.rebooted = False
        self.restarts = 0               # restarts seen (and recovered from) in this run
        self._restart_asked = False     # the case reset the HAT itself (a world action)
        self._restart_at: Optional[int] = None

    # -- identity ----------------------------------------------------------------------
    @property
    def profile(self) -> Profile:
        return self.session.profile

    @property
    def profile_exact(self) -> bool:
        return bool(getattr(self.session, "profile_exact", True))

    def feature(self, key: str) -> Any:
        return self.profile.features[key]

    def has(self, command: str) -> bool:
        return command in self.profile.commands

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
            head = raw[:cut]
            # The fence line's own CR gives CRLF first; with echo on "version" is echoed before it.
            if head.endswith(b"\r\n"):
                head = head[:-2]
            if head.endswith(b"version"):
                head = head[: -len(b"version")]
            raw = head
        return Reply(data, raw, list(self.session.events[first_event:boundary]))

    def fence(self, timeout: float) -> tuple[int, int]:
        """Send ``version`` and wait for *its* answer: the first version line after the CRLF
        of the fence's own line (a version line the test's own line printed does not count).
        Returns (index of the fence's first event, index just after its answer).

        Counting CRLFs is fast and exact on a sound link; when it finds no answer (a line ending
        lost or added on the link, a silent or restarted HAT) the link is resynchronised by
        content and the case ends with a :class:`TargetFault` saying what the target did."""
        s = self.session
        start = s.mark()
        try:
            line_no = s.send("version")

            def own_line_ending(e: Any) -> bool:
                """the CRLF (or echo) of the fence's own line"""
                return e.fields.get("host_line") == line_no

            def version_line(e: Any) -> bool:
                """the `Firmware version:` line answering the fence"""
                return e.kind == "version"

            crlf = s.expect(own_line_ending, timeout=timeout, since=start)
            boundary = _index_of(s.events, crlf, start)
            answer = s.expect(version_line, timeout=timeout, since=boundary + 1)
        except ExpectTimeout:
            raise self._recover(start, timeout) from None
        except TargetError as exc:
            raise TargetFault(DEAD if "stopped reading" not in str(exc) else NOT_READING, str(exc)) from None
        after = _index_of(s.events, answer, boundary) + 1
        if crlf.kind == "echo":
            # With echo on the prompt follows the answer; take it now so it does not open the
            # next reply.
            try:
                prompt = s.expect("prompt", timeout=min(timeout, 0.5), since=after)
                after = _index_of(s.events, prompt, after) + 1
            except AssertionError:
                pass
        self.check_reboot(after)
        return boundary, after

    def _recover(self, start: int, waited: float) -> TargetFault:
        """The counted fence found no answer: sync by content to put the link back in step, and
        say what the target did."""
        s = self.session
        try:
            sync = s.sync(1.0)
        except ExpectTimeout:
            return describe_silence(bytes(s.received[self._case_bytes:]), s.events[start:], waited + 3.0)
        except TargetError as exc:
            return TargetFault(DEAD, str(exc))
        self._next = sync.answer + 1
        self._fence_own.clear()
        banner = self._banner_since(start)
        self._scanned = self._next
        if banner is not None and not self._restart_asked:
            self.rebooted = True
            self._restart_at = banner
            return TargetFault(REBOOTED, "the HAT printed its start-up banner again during this case "
                                         f"({s.events[banner].text!r})")
        return TargetFault(GARBLED, "the reply to this case's line was garbled on the link (a line "
                                    "ending lost or added); the link was resynchronised by content")

    def _banner_since(self, start: int) -> Optional[int]:
        # The banner's first line marks a restart (FACTS §5; the bootloader prints it too).
        return self.session.events.scan(lambda e: e.kind == "banner" and e.fields.get("stage") == "help_hint",
                                        max(start, self._scanned))

    def check_reboot(self, upto: Optional[int] = None) -> None:
        """Raise TargetFault(rebooted) if a start-up banner arrived since the last look."""
        banner = self._banner_since(self._scanned)
        self._scanned = self.session.mark() if upto is None else max(self._scanned, upto)
        if banner is not None and self._restart_asked:
            self.rebooted, self._restart_at = True, banner
            return
        if banner is not None:
            self.rebooted = True
            self._restart_at = banner
            raise TargetFault(REBOOTED, "the HAT restarted during this case (its start-up banner came: "
                                        f"{self.session.events[banner].text!r})")

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
        return self.session.world(line)

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

    def cleanup_lines(self, powered: tuple[int, ...] = ()) -> List[str]:
        """What the fence between test cases sends: echo/debug off, every port quiet and in
        direct-PWM mode with a zero constant setpoint and the default limit. Ports in
        ``powered`` keep their drive: a light matrix disconnects when its power goes."""
        parts = ["echo 0", "debug 0"]
        for p in range(4):
            parts += [f"port {p}", "select"] + ([] if p in powered else ["pwm", "off"])
            if self.has("bias"):
                parts.append("bias 0")
        if self.has("pwmparams"):
            parts = parts + [f"port {p} ; pwmparams 0 0" for p in range(4)]
        # plimit is left alone: a powered light matrix needs it, and tests that depend on the
        # default limit set it themselves.
        parts += ["port 0"]
        # One line per 200 bytes at most: the line buffer holds 256 (FACTS §1).
        lines, line = [], ""
        for part in parts:
            if len(line) + len(part) + 3 > 200:
                lines.append(line)
                line = ""
            line = f"{line} ; {part}" if line else part
        return lines + [line]

    def resync(self) -> None:
        """Between cases: end any half-typed line, put the HAT back in a known state and find
        the link's place by content (harness/sync.py), whatever the last case left behind:
        half a line, a lost or extra line ending, garbage, a restart. After a restart (a
        start-up banner) the HAT is let finish starting and set up again. Reports queued before
        ``select`` took effect arrive before the sync's answer, so no drain is needed."""
        s = self.session
        self._case_bytes = len(s.received)
        for _round in range(3):
            start = s.mark()
            try:
                if not self._powered_checked:
                    s.sync(self._sync_wait())          # in step before asking `list`
                    self._powered_checked = True
                    self.powered_ports = self._ports_needing_power()
                # The lines go back to back under one sync (H10: a fence each made three round
                # trips per case); they fit the 8192-byte receive ring many times over (FACTS §1).
                lines = self.cleanup_lines(self.powered_ports)
                before = b"\r" + b"".join(line.encode() + b"\r" for line in lines)
                sync = s.sync(self._sync_wait(), before=before)
            except ExpectTimeout:
                raise describe_silence(bytes(s.received[self._case_bytes:]), s.events[start:],
                                       3 * self._sync_wait()) from None
            except TargetError as exc:
                raise TargetFault(NOT_READING if "stopped reading" in str(exc) else DEAD, str(exc)) from None
            banner = self._banner_since(self._scanned)
            self._next = sync.answer + 1
            self._fence_own.clear()
            self._scanned = self._next
            if banner is None and not self.rebooted:
                self._restart_asked = False
                return
            # The HAT restarted (now, or during the last case): its state is the power-on state
            # (echo off, ports idle), but the devices connect again and the powered ports are
            # found again; then the set-up above runs once more.
            self.rebooted = False
            self._powered_checked = False
            self.restarts += 0 if self._restart_asked else 1
            self._restart_asked = False
            self._await_started(banner if banner is not None else self._restart_at)
            self._restart_at = banner if banner is not None else self._restart_at
        raise TargetFault(REBOOTED, "the HAT restarted again each time it was set up (3 times in a row)")

    def _sync_wait(self) -> float:
        """Seconds one sync waits for its answer: a round trip with the set-up lines, at most
        ~60 ms at 115200 baud, with a wide margin (a slow link, a loaded machine)."""
        return 1.0

    def _await_started(self, banner: Optional[int]) -> None:
        """Wait (at most 3 s of HAT time) for `Done initialising ports` after the banner at
        index ``banner`` (FACTS §5: the host waits for it)."""
        s = self.session

        def started(e: Any) -> bool:
            """`Done initialising ports`"""
            return e.kind == "banner" and e.fields.get("stage") == "done"

        since = banner if banner is not None else s.mark()
        if s.events.scan(started, since) is None:
            try:
                s.expect(started, timeout=max(1.0, self.seconds(3000)), since=since)
            except ExpectTimeout:
                pass   # the sync that follows says whether the HAT answers

    def _ports_needing_power(self) -> tuple[int, ...]:
        """Ports with a device that disconnects without motor power (the light matrix, per
        devices.json): the fence must not switch their drive off."""
        from ..protocol.devices import catalogue
        from .oracles.listing import parse_list
        try:
            entries = parse_list(self.exchange("list").list_lines())
        except ValueError:
            return ()
        ports = []
        for e in entries:
            power = (catalogue().get(f"0x{e.id:02X}", {}).get("power") or {}) if e.kind == "active" else {}
            if power.get("needs_port_power_at_connect") and "disconnect" in power.get("note", ""):
                ports.append(e.port)
        return tuple(ports)
