"""Between cases and after a glitch: putting the link and the HAT back in step.

The counted fence (conformance/hat_under_test.py) is fast and exact on a sound link. When it finds no
answer, or a case begins, the link is found again *by content* (harness/sync.py): a token only
its own reply can contain, whatever came before it (half a line, a lost or extra line ending,
garbage, a restart). A start-up banner seen mid-run is a restart: the case in flight is a target
fault, and the next case's set-up waits for the HAT to finish starting and restores the suite's
preconditions (echo and debug off, ports quiet, powered ports found again). Whatever the target
did is said in one line (conformance/target_fault.py).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, List, Optional

from ..harness.errors import ExpectTimeout, TargetError
from .setup_check import SetupCheck
from .target_fault import (
    GARBLED,
    REBOOTED,
    TargetFault,
    binary_count,
    describe_silence,
    foreign,
    garbled_reply,
    target_fault_of,
)
from .trusted_clauses import TrustedClauses

__all__ = ["Resync", "BABBLE_LINES", "BABBLE_BURST", "BABBLE_BINARY", "QUIET_S"]

#: Lines no Build HAT prints (event kind ``unknown``), in one case and again in QUIET_S seconds of
#: the host asking nothing, that make the target a babbler (a flood): a HAT prints nothing unasked
#: but its reports, and those are known kinds.
BABBLE_LINES = 10
#: As many such lines in one case are a flood whatever follows: no answer is that long (a
#: release's whole help text is ~60 lines, and those are known).
BABBLE_BURST = 100
QUIET_S = 0.5
#: A stream (reports, PID lines) prints every 10 ms at most; this much HAT time without a byte
#: means it has stopped and its backlog has drained.
STREAM_QUIET_MS = 40
#: The longest the set-up waits for a stream to drain: twice a full 8192-byte TX ring at 115200.
DRAIN_MS = 1500
#: Binary bytes (not printable text, CR or LF) in one case's output above which it is garbage;
#: a test's own control bytes echoed back are a few dozen at most.
BABBLE_BINARY = 1024


class Resync:
    """The link-recovery half of :class:`conformance.link.Hat` (a mixin: it uses the Hat's
    session, event cursor and ``exchange``)."""

    if TYPE_CHECKING:   # provided by Hat
        session: Any
        _next: int
        _fence_own: set

        def exchange(self, text: Any, timeout_ms: float = ...) -> Any: ...
        def fence(self, timeout: float, between_cases: bool = False) -> tuple[int, int]: ...
        def seconds(self, hat_ms: float) -> float: ...
        def has(self, command: str) -> bool: ...
        @property
        def profile(self) -> Any: ...

    def _init_resync(self) -> None:
        #: What the run knows of the clauses the set-up relies on (conformance/trusted_clauses.py).
        self.clauses = TrustedClauses()
        self._powered_checked = False
        #: Devices had their time to connect (conformance/needs.py waits for them once per run,
        #: and again after a restart).
        self.devices_settled = False
        #: Ports whose drive the fence leaves alone (devices that need power to stay connected).
        self.powered_ports: tuple[int, ...] = ()
        self._scanned = self.session.mark()  # events before this were looked at for a start-up banner
        self._case_bytes = 0            # byte offset where the current case's traffic began
        self._case_events = 0           # event index where the current case's traffic began
        self._cases = 0                 # cases begun (resyncs)
        self._babbled_in = -2           # the case in which the target was last heard babbling
        #: The HAT restarted; the next resync puts the suite's preconditions back.
        self.rebooted = False
        self.restarts = 0               # restarts seen (and recovered from) in this run
        self._restart_asked = False     # the case reset the HAT itself (a world action)
        self._restart_at: Optional[int] = None
        #: Which set-up commands the target accepts (conformance/setup_check.py).
        self.setup_check = SetupCheck()
        #: Lines said about refused set-up commands not yet shown (the case fixture takes them).
        self.setup_said: List[str] = []

    def _recover(self, start: int, start_byte: int, waited: float) -> TargetFault:
        """The counted fence found no answer: sync by content to put the link back in step, and
        say what the target did."""
        s = self.session
        try:
            sync = s.sync(1.0, separate=not self.clauses.trusted("separator"))
        except ExpectTimeout:
            return describe_silence(bytes(s.received[start_byte:]), s.events[start:], waited + 3.0)
        except TargetError as exc:
            return target_fault_of(exc)
        self._next = sync.after
        self._fence_own.clear()
        banner = self._banner_since(start)
        self._scanned = self._next
        if banner is not None and not self._restart_asked:
            self.rebooted = True
            self._restart_at = banner
            return TargetFault(REBOOTED, "the HAT printed its start-up banner again during this case "
                                         f"({s.events[banner].text!r})")
        return self.babble() or garbled_reply(bytes(s.received[self._case_bytes:]))

    def _banner_since(self, start: int) -> Optional[int]:
        # The banner's first line marks a restart (docs/FIRMWARE-BEHAVIOUR.md#fb-startup; the
        # bootloader prints it too, #fb-bootloader).
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

    def after_reset(self, since: int) -> None:
        """The run reset the HAT (conformance/plugin/recovery.py) at event index ``since``: the next
        set-up waits for its start-up and restores the preconditions, as after a restart, without
        counting it as one the HAT did by itself."""
        self.rebooted = True
        self._restart_asked = True
        self._restart_at = since
        self._scanned = self.session.mark()
        self._powered_checked = False
        self.devices_settled = False

    def babble(self) -> Optional[TargetFault]:
        """A target fault if the target babbled during this case: binary garbage, or a flood of
        lines no Build HAT prints that goes on while the host asks nothing. A check that failed
        in such a case failed because of the link, not of the protocol."""
        s = self.session
        received = bytes(s.received[self._case_bytes:])
        if binary_count(received) > BABBLE_BINARY:
            return garbled_reply(received)
        unknown = sum(1 for e in s.events[self._case_events:] if foreign(e))
        if unknown == 0:
            return None
        if unknown >= BABBLE_BURST:
            self._babbled_in = self._cases
            return TargetFault(GARBLED, f"a flood of lines no Build HAT prints: {unknown:,} came during this "
                                        "case")
        # Unknown lines (even one: a flood that began as the case ended): a firmware answering
        # wrongly, or something babbling? Listen a moment without asking anything; a HAT (even a
        # buggy one) prints no such lines unasked.
        mark, deadline = s.mark(), s.clock() + QUIET_S
        unasked: List[Any] = []
        while len(unasked) < BABBLE_LINES and s.clock() < deadline:
            s.wait_new(s.mark(), deadline - s.clock())
            unasked = [e for e in s.events[mark:] if foreign(e)]
        if len(unasked) >= BABBLE_LINES:
            self._babbled_in = self._cases
            return TargetFault(GARBLED, f"a flood of lines no Build HAT prints: {len(unasked):,} more came "
                                        f"while the host asked nothing (the first: {unasked[0].text[:60]!r})")
        if self._babbled_in >= self._cases - 1:
            # The flood heard in the last case ended during this one.
            return TargetFault(GARBLED, f"{unknown:,} lines no Build HAT prints came during this case, the "
                                        "end of the flood heard in the case before")
        return None

    def cleanup_commands(self, powered: tuple[int, ...] = ()) -> List[str]:
        """What the set-up between test cases puts the HAT back with, one command each: echo/debug
        off, every port quiet and in direct-PWM mode with a zero constant setpoint and the default
        bias and PWM parameters, as far as the profile has those commands. Ports in ``powered``
        keep their drive: a light matrix disconnects when its power goes."""
        parts = ["echo 0", "debug 0"]
        for p in range(4):
            parts += [f"port {p}", "select"] + ([] if p in powered else ["pwm", "off"])
            if self.profile.has("bias"):      # the profile's table: a cleanup is never a verdict
                parts.append("bias 0")
            if self.profile.has("pwmparams"):
                parts.append("pwmparams 0 0")
        # plimit is left alone: a powered light matrix needs it, and tests that depend on the
        # default limit set it themselves.
        return parts + ["port 0"]

    def cleanup_lines(self, powered: tuple[int, ...] = (), separate: bool = False) -> List[str]:
        """The set-up's lines: :meth:`cleanup_commands` less those the target refuses (each
        replaced by what resets the same, conformance/setup_check.py), several to a line.
        ``separate``: one command per line (the `;` separator is not trusted)."""
        parts = self.setup_check.commands(self.cleanup_commands(powered))
        if separate:
            return parts
        # One line per 200 bytes at most: the line buffer holds 256
        # (docs/FIRMWARE-BEHAVIOUR.md#fb-line-buffer).
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
        self._case_events = s.mark()
        self._cases += 1
        relearnt = False
        for _round in range(3):
            start, began = s.mark(), s.clock()
            try:
                if not self._powered_checked or self.setup_check.due:
                    self._find_place()                # in step before asking `list`
                if not self._powered_checked:
                    self._powered_checked = True
                    self.powered_ports = self._ports_needing_power()
                if self.setup_check.due:                    # each set-up command on its own, answer seen
                    self.setup_said += self.setup_check.learn(self.cleanup_commands(self.powered_ports),
                                                        self.exchange)
                # The lines go back to back under one sync (H10: a fence each made three round
                # trips per case); they fit the 8192-byte receive ring many times over
                # (docs/FIRMWARE-BEHAVIOUR.md#fb-uart).
                lines = self.cleanup_lines(self.powered_ports, separate=not self.clauses.trusted("separator"))
                sent = s.mark()
                after = self._find_place(b"\r" + b"".join(line.encode() + b"\r" for line in lines))
                if self.setup_check.refusals_seen(s.events[sent:after]) and not relearnt:
                    relearnt = True   # an `Error` in the set-up's output: learn again, set up again
                    continue
            except ExpectTimeout:
                raise describe_silence(bytes(s.received[self._case_bytes:]), s.events[start:],
                                       s.clock() - began) from None
            except TargetError as exc:
                raise target_fault_of(exc) from None
            banner = self._banner_since(self._scanned)
            self._next = after
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
            self.setup_check.due = True             # a restart may have brought other firmware
            self.devices_settled = False
            self.restarts += 0 if self._restart_asked else 1
            self._restart_asked = False
            self._await_started(banner if banner is not None else self._restart_at)
            self._restart_at = banner if banner is not None else self._restart_at
        raise TargetFault(REBOOTED, "the HAT restarted again each time it was set up (3 times in a row)")

    def _find_place(self, before: bytes = b"") -> int:
        """Send ``before`` (set-up lines) and find the link's place after their output; returns
        the index of the first event after it. By content (a sync) once the echo clause has
        passed; before that, and if it failed, by the counted ``version`` fence, with the sync
        only as the way back when the count finds no answer (conformance/trusted_clauses.py)."""
        s = self.session
        separate = not self.clauses.trusted("separator")
        if not self.clauses.trusted("echo"):
            if before:
                s.send_raw(before)
            try:
                return self.fence(self._sync_wait(), between_cases=True)[1]
            except ExpectTimeout:
                pass        # a line ending lost or added, garbage, a full TX ring: see below
        else:
            try:
                return s.sync(self._sync_wait(), before=before, separate=separate, attempts=1).after
            except ExpectTimeout:
                pass
        # Output still draining from a stream the last case left on (the set-up lines have
        # stopped it) may have filled the HAT's TX ring, which drops output bytes
        # (docs/FIRMWARE-BEHAVIOUR.md#fb-tx-ring):
        # wait the stream out, then find the place by content, the set-up lines sent again.
        self._wait_out_stream()
        return s.sync(self._sync_wait(), before=before, separate=separate).after

    def _wait_out_stream(self) -> None:
        """Wait until the HAT has been quiet for STREAM_QUIET_MS of HAT time (at most DRAIN_MS):
        a full TX ring drains in 8192 bytes / 11520 bytes/s = 0.71 s at 115200 baud."""
        self.session.drain(quiet=self.seconds(STREAM_QUIET_MS), limit=self.seconds(DRAIN_MS))

    def _sync_wait(self) -> float:
        """Seconds one sync waits for its answer: a round trip with the set-up lines, at most
        ~60 ms at 115200 baud, with a wide margin (a slow link, a loaded machine)."""
        return 1.0

    def _await_started(self, banner: Optional[int]) -> None:
        """Wait (at most 3 s of HAT time) for `Done initialising ports` after the banner at
        index ``banner`` (docs/FIRMWARE-BEHAVIOUR.md#fb-startup: the host waits for it)."""
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
