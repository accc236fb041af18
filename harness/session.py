"""A session with one target: lines in, typed events out, every byte into the transcript.

A reader thread pulls bytes from the target as they arrive, so times are taken when the
bytes came (not when a test got round to looking) and the transcript holds every byte
received even if the test, the run or the target dies. Host bytes are written to the
transcript before they go to the target, so a reply never precedes its command there.

Event times (``Event.t``) are real milliseconds since the session opened. Transcript
times are HAT milliseconds (real time x the target's time_scale) since the origin, which
is the open, or the moment :meth:`Session.set_origin` was called (the script start).

Virtual-time targets (capability ``virtual_time`` and a ``now`` attribute, e.g. the
in-process emulator) move only when read, so for them no reader thread runs: the session
reads in the caller's thread, and timeouts and waits are spent in HAT time (seconds x
time_scale), not wall-clock time. Their ``Event.t`` is HAT ms / time_scale, so the same
arithmetic holds for both kinds. A virtual-time target behind a wrapper that hides ``now``
gets a reader thread that reads it one HAT millisecond at a time on a schedule locked to
the wall clock, so it runs in real time (x time_scale) as hardware would.
"""
from __future__ import annotations

import atexit
import contextlib
import os
import threading
import time
import weakref
from typing import Callable, List, Optional, Union

from ..protocol.profiles import Profile, get_profile
from .conversation import Conversation
from .errors import NeedsCapability, SessionError, TargetError
from .events import Event
from .history import ByteHistory, EventHistory
from .identify import Identification
from .line_splitter import LineSplitter
from .matching import Match, describe_events
from .sync import SyncResult
from .targets.base import Target
from .transcript import TranscriptWriter

__all__ = ["Session", "Match", "describe_events", "SyncResult"]

_READ_SLICE = 0.05      # how long one read waits, so close() is noticed quickly

_live_sessions: weakref.WeakSet[Session] = weakref.WeakSet()


@atexit.register
def _flush_live_sessions() -> None:
    # A run that ends without closing its sessions still leaves partial output on disk.
    for s in list(_live_sessions):
        s._flush_transcript()


def _event_weight(e: Event) -> int:
    # What an event costs in memory, roughly: its bytes, its text and the object around them.
    return 2 * len(e.raw) + 300


class Session(Identification, Conversation):
    """The API of docs/DEVELOPING.md ("Session"), plus:

    ``mark()`` (an index for ``expect(..., since=)``), ``drain()``, ``reset(bootloader)``,
    ``identify()`` (what answers, again), ``bytes_since(offset, timeout)`` (raw bytes),
    ``set_origin()`` / ``transcript_now()`` / ``attach_transcript(writer)`` (for runners that
    write the transcript once the firmware is known), ``version_string``, ``notes`` (remarks
    such as "unknown firmware version ..."), ``echo_on``, ``partial`` (output not yet ended by
    CRLF), ``sent`` (every byte sent) and ``virtual`` (read in HAT time, see the module doc).
    ``profile`` is None while the target is in its bootloader (unless one was given).
    """

    def __init__(self, target: Target, transcript: Union[TranscriptWriter, str, os.PathLike, None] = None,
                 profile: Union[Profile, str, int, None] = None):
        self.target = target
        self._own_writer = not isinstance(transcript, TranscriptWriter) and transcript is not None
        self._transcript_path = None if isinstance(transcript, TranscriptWriter) else transcript
        self.transcript: Optional[TranscriptWriter] = transcript if isinstance(transcript, TranscriptWriter) \
            else None
        self._requested_profile = get_profile(profile) if profile is not None and \
            not isinstance(profile, Profile) else profile
        self.profile: Optional[Profile] = self._requested_profile
        self.profile_exact = True
        self.profile_why = ""                # why this profile, when no release was named (identify.py)
        self.in_bootloader = False
        self.version_string: Optional[str] = None
        self.notes: List[str] = []          # remarks for the report, e.g. an unknown firmware version
        # Bounded (harness/history.py): the transcript on disk is the complete record.
        self.events: EventHistory[Event] = EventHistory(weigh=_event_weight)
        self.received = ByteHistory()
        self.sent = ByteHistory()
        # (t ms, "host"|"hat", bytes) for attach_transcript (its history): the recent past only
        self._log: EventHistory[tuple] = EventHistory(weigh=lambda entry: len(entry[2]) + 64)
        self.echo_on = False                # last seen: did the HAT echo our line?
        self._splitter = LineSplitter()
        self._cond = threading.Condition()
        self._reader: Optional[threading.Thread] = None
        self._stop = threading.Event()
        self._error: Optional[BaseException] = None
        self._cursor = 0
        self._t0 = time.monotonic()
        self._origin_ms = 0.0
        self._closed = False
        self._opened = False
        self.virtual = bool(target.has("virtual_time") and hasattr(type(target), "now"))
        # A virtual-time target is one object stepped by whoever calls it: when a reader
        # thread runs for it (paced, see _paced_read_loop), every call to it is serialised.
        # Real links read and write concurrently, so for them the lock is a no-op.
        self._io_lock = threading.Lock() if target.has("virtual_time") else contextlib.nullcontext()
        self._hat0 = 0.0
        # H10 (make bench): HAT milliseconds spent in waits the caller asked for (wait_ms,
        # collect, note_wait): the protocol's mandatory waiting, against which a run's
        # overhead is measured. Only ever added to; readers take differences.
        self.waited_hat_ms = 0.0

    # -- time ----------------------------------------------------------------------------
    def _hat_now(self) -> Optional[float]:
        try:
            return float(self.target.now)  # type: ignore[attr-defined]
        except (TargetError, AttributeError, TypeError):
            return None

    def now_ms(self) -> float:
        """Milliseconds since the session opened (the clock of ``Event.t``): real time, or
        for a virtual-time target its HAT time divided by the time scale."""
        if self.virtual:
            hat = self._hat_now()
            if hat is not None:
                return (hat - self._hat0) / self.time_scale
        return (time.monotonic() - self._t0) * 1000.0

    def clock(self) -> float:
        """Seconds on the session's clock: the wall clock, or for a virtual-time target its
        HAT time divided by the time scale. Deadlines and durations measured by callers use
        this, so a virtual-time run never waits on the wall clock."""
        return self.now_ms() / 1000.0 if self.virtual else time.monotonic()

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` pass on :meth:`clock` (a virtual-time target is stepped, not waited
        for). Unlike :meth:`wait_ms` it counts nothing as mandatory waiting."""
        if seconds <= 0:
            self._check()
        elif self.virtual:
            self._wait_index(lambda e: False, len(self.events), seconds)
        else:
            time.sleep(seconds)
            self._check()

    @property
    def time_scale(self) -> float:
        return float(self.target.time_scale or 1.0)

    def _transcript_t(self, t_ms: float) -> float:
        return (t_ms - self._origin_ms) * self.time_scale

    def transcript_now(self) -> float:
        """The transcript time of this moment (HAT ms since the origin)."""
        return self._transcript_t(self.now_ms())

    def set_origin(self) -> None:
        """Make transcript time 0 now (the start of a script); earlier events get t < 0."""
        with self._cond:
            self._origin_ms = self.now_ms()

    # -- open / close ----------------------------------------------------------------------
    def open(self, detect: bool = True, timeout: float = 2.0) -> Session:
        """Open the target (unless already open), start reading and, with ``detect``, resync
        and find out what answers: firmware (``profile``) or bootloader (``in_bootloader``)."""
        if not self.target.is_open:
            self.target.open()
        self._t0 = time.monotonic()
        self._opened = True
        try:
            self._hat0 = (self._hat_now() or 0.0) if self.virtual else 0.0
            if self._own_writer and self._transcript_path is not None:
                self.transcript = TranscriptWriter(self._transcript_path, self._meta())
            if not self.virtual:
                self._reader = threading.Thread(target=self._read_loop, daemon=True,
                                                name=f"session-reader {self.target.url}")
                self._reader.start()
            _live_sessions.add(self)
            if detect:
                self._detect(timeout)
        except BaseException:
            self.close()   # the target was opened here: never leave it (or its process) behind
            raise
        return self

    def _meta(self) -> dict:
        meta = {"target": self.target.url, "tool": "buildhat-conformance session",
                "firmware": str(self.profile.number) if self.profile else "unknown"}
        return meta

    def close(self) -> None:
        """Stop reading, flush the transcript (a partial line is kept) and close the target."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        if self._reader is not None and self._reader is not threading.current_thread():
            self._reader.join(timeout=2.0)
        with self._cond:
            t_end = self._transcript_t(self.now_ms())
        try:
            self.target.close()
        finally:
            with self._cond:
                if self.transcript is not None:
                    if self._own_writer:
                        self.transcript.close(t_end)
                    else:
                        self.transcript.flush_partial(t_end)
            _live_sessions.discard(self)

    def __enter__(self) -> Session:
        if not self._opened:
            self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def attach_transcript(self, writer: TranscriptWriter, history: bool = True) -> None:
        """Start writing to ``writer`` (e.g. once the firmware is known for its meta line);
        with ``history``, everything sent and received so far is written first, in order."""
        with self._cond:
            if history:
                for t, kind, data in self._log:
                    if kind == "host":
                        writer.host(self._transcript_t(t), data)
                    else:
                        writer.hat(self._transcript_t(t), data)
            self.transcript = writer
            self._own_writer = False

    def _flush_transcript(self) -> None:
        with self._cond:
            if self.transcript is not None:
                self.transcript.flush_partial()

    # -- reading -------------------------------------------------------------------------------
    def _read_loop(self) -> None:
        """The reader thread (real-time targets)."""
        try:
            if self.target.has("virtual_time"):
                self._paced_read_loop()
                return
            while not self._stop.is_set():
                if not self._read_once(_READ_SLICE):
                    return
        except BaseException as exc:  # a harness bug must fail the waiting caller, not hang it
            with self._cond:
                self._error = exc
                self._cond.notify_all()

    def _paced_read_loop(self) -> None:
        # A virtual-time target seen through a wrapper that hides its clock (``now``): a
        # reader thread would run it flat out, its HAT time racing ahead of the wall clock.
        # So it is read one HAT millisecond at a time (a read moves its clock by at most its
        # timeout) on a schedule locked to the wall clock: real time, as on hardware.
        step = 0.001 / self.time_scale
        began, hat_ms = time.monotonic(), 0
        while not self._stop.is_set():
            delay = began + hat_ms * step - time.monotonic()
            if delay > 0:
                time.sleep(min(delay, _READ_SLICE))
                continue
            # a hair under 1 ms, so a target that rounds its budget up still steps just one
            if not self._read_once(step * (1 - 1e-9)):
                return
            hat_ms += 1

    def _read_once(self, timeout: float) -> bool:
        """One target read; records what came. False once the target has failed."""
        try:
            with self._io_lock:
                data = self.target.read(timeout)
        except BaseException as exc:  # the target went away: keep it for the caller
            with self._cond:
                if not self._stop.is_set():
                    self._error = exc
                    if self.transcript is not None:
                        t = self._transcript_t(self.now_ms())
                        self.transcript.flush_partial(t)
                        self.transcript.note(t, f"target error: {exc}")
                self._cond.notify_all()
            return False
        if data:
            self._received(data)
        elif self.transcript is not None:
            with self._cond:
                self.transcript.flush_stale()   # a half line waiting for its CRLF goes to disk
        return True

    def _received(self, data: bytes) -> None:
        with self._cond:
            t = self.now_ms()
            self.received += data
            self._log.append((t, "hat", data))
            if self.transcript is not None:
                self.transcript.hat(self._transcript_t(t), data)
                self.transcript.flush_stale()
            self.events.extend(self._splitter.feed(data, t))
            self._cond.notify_all()

    def _check(self) -> None:
        if self._error is not None:
            err = self._error
            if isinstance(err, TargetError):
                again = type(err)(f"{err}\n{describe_events(self.events[self._cursor:], self.partial)}")
                again.__dict__.update(err.__dict__)    # the same kind of fault, with what it carried
                raise again from err
            raise TargetError(f"reading from {self.target.url} failed: {err!r}") from err
        if not self._opened or self._closed:
            raise SessionError("the session is not open (call open() first)")

    # -- sending -------------------------------------------------------------------------------
    def send_raw(self, data: bytes) -> List[int]:
        """Send exactly these bytes. Returns the numbers of the host lines they ended (one per CR)."""
        self._check()
        data = bytes(data)
        with self._cond:
            t = self.now_ms()
            if self.transcript is not None:
                self.transcript.host(self._transcript_t(t), data)
            self.sent += data
            self._log.append((t, "host", data))
            ended = self._splitter.host_sent(data)
        # Written outside the event lock: a target that blocks until we read must not stall
        # the reader. (The I/O lock only serialises targets that are not thread-safe.)
        with self._io_lock:
            self.target.write(data)
        return ended

    def send(self, text: str) -> int:
        """Send one command line followed by CR (never CRLF: LF would start the next line).
        Returns the host line number (see ``Event.fields["host_line"]``)."""
        if "\r" in text or "\n" in text:
            raise ValueError("send() takes one line without CR/LF; use send_raw() for exact bytes")
        return self.send_raw(text.encode("utf-8") + b"\r")[-1]

    # -- waiting -------------------------------------------------------------------------------
    @property
    def partial(self) -> bytes:
        """Received bytes not yet ended by CRLF (and not a prompt)."""
        return self._splitter.partial

    def _wait_index(self, pred: Callable[[Event], bool], start: int, timeout: float) -> Optional[int]:
        """Index of the first event from ``start`` on that satisfies pred, or None after
        ``timeout`` seconds (wall clock; HAT seconds / time_scale for virtual-time targets).
        One loop for both kinds of target; only how the next bytes come differs (``more``)."""
        more = self._step_virtual(timeout) if self.virtual else self._step_real(timeout)
        i = start
        with contextlib.nullcontext() if self.virtual else self._cond:
            while True:
                found = self.events.scan(pred, i)
                if found is not None:
                    return found
                i = len(self.events)
                self._check()
                if not more():
                    return None

    def _step_real(self, timeout: float) -> Callable[[], bool]:
        """Real time: wait (holding ``_cond``) for the reader thread's next event, until the deadline."""
        deadline = time.monotonic() + timeout

        def more() -> bool:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self._cond.wait(min(left, 0.25))
            return True
        return more

    def _step_virtual(self, timeout: float) -> Callable[[], bool]:
        """Virtual time: each read moves the HAT on until output appears or the budget is spent."""
        budget_ms = [timeout * 1000.0 * self.time_scale]

        def more() -> bool:
            if budget_ms[0] <= 0:
                return False
            before, got = self._hat_now() or 0.0, len(self.received)
            if not self._read_once(budget_ms[0] / 1000.0 / self.time_scale):
                self._check()
            spent = (self._hat_now() or before) - before
            if spent > 0:
                budget_ms[0] -= spent
            elif len(self.received) == got:
                budget_ms[0] = 0  # neither time nor bytes moved: nothing more will come
            return True
        return more

    def poll(self) -> None:
        """Take in what the target has already sent, letting no time pass (a virtual-time
        target is read without being stepped; a real-time one has its reader thread)."""
        self._check()
        if self.virtual:
            self._read_once(0)

    def wait_new(self, count: int, timeout: float) -> bool:
        """Block until there are more than ``count`` events, at most ``timeout`` seconds (wall
        clock; HAT seconds / time_scale for virtual-time targets). True if one came. Waiters
        wake as the event arrives, not on a polling period (H10: 10 ms polls cost ~5 ms a wait)."""
        return self._wait_index(lambda e: True, count, max(0.0, timeout)) is not None

    def wait_ms(self, ms: float) -> None:
        """Let ``ms`` milliseconds of HAT time pass (real time divided by the time scale)."""
        if ms > 0:
            self.note_wait(ms)
        self.sleep(ms / 1000.0 / self.time_scale)

    def note_wait(self, hat_ms: float) -> None:
        """Count ``hat_ms`` of HAT time as waiting the protocol requires (H10: callers that
        wait by other means than wait_ms/collect, e.g. for an event the HAT prints later)."""
        self.waited_hat_ms += max(0.0, float(hat_ms))

    def bytes_since(self, offset: int, timeout: float) -> bytes:
        """Received bytes from absolute ``offset`` on, waiting at most ``timeout`` seconds (wall
        clock; HAT seconds / time_scale for virtual-time targets) for one to come. For a byte
        protocol that is not a line per command, the bootloader's (harness/bootloader/)."""
        if self.virtual:
            if len(self.received) <= offset and timeout > 0:
                self._read_once(timeout)
        else:
            deadline = time.monotonic() + timeout
            with self._cond:
                while len(self.received) <= offset:
                    self._check()
                    left = deadline - time.monotonic()
                    if left <= 0:
                        break
                    self._cond.wait(min(left, 0.25))
        self._check()
        return bytes(self.received[offset:])

    def forget_failure(self) -> None:
        """The target's HAT died and was started again (a firmware in the loop, where a crash is a
        finding and the run goes on): reading from it goes on. Virtual-time sessions only: their
        reads are the caller's, no reader thread ended with the failure."""
        if not self.virtual:
            raise SessionError("only a virtual-time session can go on after its target failed")
        with self._cond:
            self._error = None

    def mark(self) -> int:
        """The index the next event will have (for ``expect(..., since=mark)``)."""
        with self._cond:
            return len(self.events)

    # -- world -----------------------------------------------------------------------------
    def world(self, line: str) -> str:
        """Perform a world action (``@plug 1 0x30``) through the target's control."""
        word = line.strip().lstrip("@").split(" ", 1)[0]
        control = self.target.control
        if control is None:
            raise NeedsCapability(word, self.target.url)
        if control.capabilities and word not in control.capabilities:
            raise NeedsCapability(word, self.target.url,
                                  f"its control offers {', '.join(sorted(control.capabilities))}")
        with self._io_lock:
            reply = control.action(line.strip())
        if self.transcript is not None:
            with self._cond:
                self.transcript.note(self._transcript_t(self.now_ms()), f"world {line.strip()} -> {reply}")
        return reply
