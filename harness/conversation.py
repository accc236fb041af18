"""The host's side of the conversation on a session: expect an event, fence with `version`,
send a command and take what it produced, collect, drain, and sync by content.

A mixin of :class:`~.session.Session` (it works on the session's events, cursor and lock);
kept apart from the session's link (open, read loop, send, transcript) because finding one's
own answer in the stream is its own job.
"""
from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Callable, List, Optional

from .errors import ExpectTimeout
from .events import Event
from .matching import Match, describe_events, matcher
from .sync import SEPARATE_TAIL, SYNC_ATTEMPTS, SyncResult, new_token, sync_bytes

__all__ = ["Conversation", "FENCE_KINDS", "STREAM_KINDS"]

FENCE_KINDS = ("version", "bootloader_version")
#: Lines a HAT prints on its own, again and again while a stream is on (FIRMWARE-BEHAVIOUR.md#fb-data,
#: #fb-debug).
STREAM_KINDS = frozenset({"mode_data", "combi_data", "var_data", "pid_debug", "data_debug"})


def _restart_line(e: Event) -> bool:
    """the first line of a start-up banner (FIRMWARE-BEHAVIOUR.md#fb-async, #fb-bootloader)"""
    return e.kind == "banner" and e.fields.get("stage") == "help_hint"


class Conversation:
    """Mixin: ``expect``, ``fence``, ``command``, ``collect``, ``drain``, ``resync``, ``sync``."""

    if TYPE_CHECKING:   # provided by Session
        target: Any
        events: Any
        received: Any
        echo_on: bool
        _cond: Any
        _cursor: int
        _splitter: Any

        @property
        def partial(self) -> bytes: ...
        def send(self, text: str) -> int: ...
        def send_raw(self, data: bytes) -> List[int]: ...
        def mark(self) -> int: ...
        def note_wait(self, hat_ms: float) -> None: ...
        def _check(self) -> None: ...
        def _note_answer(self, answer: Event) -> None: ...
        def _wait_index(self, pred: Callable[[Event], bool], start: int, timeout: float) -> Optional[int]: ...

        @property
        def time_scale(self) -> float: ...

    def expect(self, match: Match, timeout: float = 2.0, since: Optional[int] = None) -> Event:
        """The first event since the cursor (or index ``since``) that matches; consumes up to it.

        ``match``: an event kind (``"vin"``), a regular expression searched in the text, or a
        predicate. On timeout raises :class:`ExpectTimeout` saying what did arrive.
        """
        pred, what = matcher(match)
        start = self._cursor if since is None else since
        i = self._wait_index(pred, start, timeout)
        if i is None:
            arrived = self.events[start:]
            raise ExpectTimeout(f"expected {what} within {timeout:g} s from {self.target.url}; "
                                f"{describe_events(arrived, self.partial)}", arrived, self.partial)
        self._cursor = i + 1
        return self.events[i]

    def fence(self, timeout: float = 2.0) -> List[Event]:
        """Send ``version`` and wait for its answer (firmware or bootloader). Returns the events
        from the cursor up to the fence's own line; consumes through the answer (and the prompt
        that follows it when echo is on)."""
        start = self._cursor
        with self._cond:
            sent_at = len(self.events)
        line_no = self.send("version")
        own_line_seen = False

        def after_own_line(e: Event) -> bool:
            # The answer is the first version line after the blank/echo of our own CR; an
            # earlier one answers an earlier `version` (e.g. a command that was `version`).
            nonlocal own_line_seen
            if e.fields.get("host_line") == line_no:
                own_line_seen = True
            return own_line_seen and e.kind in FENCE_KINDS

        i = self._wait_index(after_own_line, sent_at, timeout)
        if i is None:
            # Either nothing answered, or a CRLF got lost (a noisy link) so that ours was taken
            # for an earlier line's: forget the waiting lines so the next fence is in step.
            with self._cond:
                self._splitter.forget_pending()
        if i is None:
            arrived = self.events[start:]
            raise ExpectTimeout(f"no answer to `version` within {timeout:g} s from {self.target.url}; "
                                f"{describe_events(arrived, self.partial)}", arrived, self.partial)
        answer = self.events[i]
        boundary = i
        for j in range(max(sent_at, self.events.dropped), i):
            if self.events[j].fields.get("host_line") == line_no:
                boundary = j
                self.echo_on = self.events[j].kind == "echo"
                break
        self._note_answer(answer)
        self._cursor = i + 1
        if self.echo_on or answer.kind == "bootloader_version":
            # The prompt follows the answer when echo is on; take it so it is not the next
            # command's first event. A short wait: it is sent right after the line.
            k = self._wait_index(lambda e: e.kind in ("prompt", "bootloader_prompt"), i + 1,
                                 min(timeout, 0.5))
            if k is not None and k == i + 1:
                self._cursor = k + 1
        return self.events[start:boundary]

    def command(self, text: str, timeout: float = 2.0) -> List[Event]:
        """Send one line, then fence. Returns every event the line produced (its blank or
        echo line first, then its output and prompt; asynchronous lines that arrived
        meanwhile are included too)."""
        self._cursor = len(self.events)
        self.send(text)
        return self.fence(timeout)

    def collect(self, seconds: float) -> List[Event]:
        """Every event that arrives during the next ``seconds`` (real time; callers scale by
        time_scale). Earlier unconsumed events are not included but skipped: after it the
        cursor is at the end."""
        with self._cond:
            start = len(self.events)
        self.note_wait(seconds * 1000.0 * self.time_scale)   # H10: mandatory waiting
        self._wait_index(lambda e: False, start, seconds)
        with self._cond:
            out = self.events[start:]
            self._cursor = len(self.events)
        return out

    def drain(self, quiet: float = 0.15, limit: float = 2.0) -> List[Event]:
        """Wait until nothing has arrived for ``quiet`` seconds (at most ``limit``); returns and
        consumes everything since the cursor."""
        start = self._cursor
        end = time.monotonic() + limit
        spent = 0.0
        while time.monotonic() < end and spent < limit:
            with self._cond:
                n = len(self.received)
            self._wait_index(lambda e: False, len(self.events), quiet)
            spent += quiet   # bounds virtual-time drains, where the wall clock hardly moves
            if len(self.received) == n:
                break
        self._check()
        with self._cond:
            self._cursor = len(self.events)
            return self.events[start:]

    def resync(self, timeout: float = 2.0) -> List[Event]:
        """Between tests: drain what is still coming, then fence; when the fence finds no
        answer (a line ending lost on the link), sync by content. Returns what was drained."""
        drained = self.drain()
        with self._cond:
            self._splitter.forget_pending()   # after a quiet spell no CRLF is still owed
        try:
            self.fence(timeout)
        except ExpectTimeout:
            self.sync(timeout / SYNC_ATTEMPTS)
        return drained

    def sync(self, timeout: float = 1.0, before: bytes = b"", attempts: int = SYNC_ATTEMPTS,
             separate: bool = False) -> SyncResult:
        """Find our own reply by content (harness/sync.py), whatever came before it. Sends
        ``before`` (e.g. set-up lines) and a sync, up to ``attempts`` times, waiting ``timeout``
        seconds for each (HAT seconds / time_scale for virtual-time targets). Leaves echo off and
        the cursor after the answer (``separate``: one command a line, no `;`; the cursor after
        the echo of its closing ``echo 0``); forgets every line ending still owed (all are
        answered). Raises ExpectTimeout when no attempt came back whole."""
        start = self.mark()
        for attempt in range(1, attempts + 1):
            token = new_token()
            tail = b"\x00" + token
            self.send_raw(before + sync_bytes(token, separate))

            def own_echo(e: Event, tail: bytes = tail) -> bool:
                """the echo of the sync's own token"""
                return e.raw.endswith(tail)

            echo = self._wait_index(own_echo, start, timeout)
            if echo is None:
                continue
            # A stream still draining (reports, PID lines: whole lines, #fb-data-lines, #fb-debug-pid) may
            # put a line between the echo and the answer: set aside, it is not the answer.
            answer = self._wait_index(lambda e: e.kind not in STREAM_KINDS, echo + 1, timeout)
            if answer is None or self.events[answer].kind != "version":
                continue     # the answer was garbled: the next attempt brings a fresh token
            last = answer
            if separate:
                closing = self._wait_index(lambda e: e.raw.endswith(SEPARATE_TAIL), answer + 1, timeout)
                if closing is None:
                    continue
                last = closing
            with self._cond:
                self._splitter.forget_pending()
                banner = self.events.scan(_restart_line, start)
            self.echo_on = False
            self._note_answer(self.events[answer])
            self._cursor = last + 1
            return SyncResult(echo, answer, attempt, token,
                              banner if banner is not None and banner < answer else None, last)
        arrived = self.events[start:]
        raise ExpectTimeout(f"no answer to {attempts} syncs (`version` with a token), {timeout:g} s each, "
                            f"from {self.target.url}; {describe_events(arrived, self.partial)}",
                            arrived, self.partial)
