"""What answers on a session: firmware (and which profile judges it) or bootloader, found again
after a reset or a load, and, when nothing sensible answers, a diagnosis in the user's terms.

A mixin of :class:`~.session.Session` (it works on the session's own state: profile, notes,
events); kept apart because choosing a profile and explaining a silent link are their own job.
"""
from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any, List, Optional

from ..protocol.profiles import Profile, get_profile, load_profiles, resolve_version
from .errors import BrokenClause, ExpectTimeout, NeedsCapability, TargetError
from .events import Event
from .hat_evidence import FLOOD_WINDOW_MS, broken_version, power_fault_flood
from .matching import describe_events

__all__ = ["Identification", "OPEN_ATTEMPTS"]

OPEN_ATTEMPTS = 3      # like the Python library, `version` is resent when nothing answers


def _unreadable(version_text: str) -> tuple[Profile, str]:
    """The profile for a `version` line with no number where the document puts it (the version
    clause fails, conformance/cases/test_link_clauses.py), and one line saying why that one:
    the release whose number the line holds elsewhere (``v1737564117``), else the latest."""
    for digits in re.findall(r"[0-9]+", version_text):
        known = load_profiles().get(int(digits))
        if known is not None:
            return known, (f"its version line has no number where the number goes; the number {digits} "
                           f"in it is {known.name}'s")
    latest = get_profile(None)
    return latest, f"its version line has no version number: {latest.name} is the latest release"


class Identification:
    """Mixin: ``profile``, ``profile_exact``, ``profile_why``, ``in_bootloader``, ``version_string``,
    ``notes``."""

    if TYPE_CHECKING:   # provided by Session
        target: Any
        _splitter: Any
        _io_lock: Any
        transcript: Any
        events: Any
        received: Any
        _cond: Any
        _requested_profile: Optional[Profile]

        @property
        def partial(self) -> bytes: ...
        def drain(self, quiet: float = ..., limit: float = ...) -> List[Event]: ...
        def fence(self, timeout: float = ...) -> List[Event]: ...
        def _transcript_t(self, t_ms: float) -> float: ...
        def now_ms(self) -> float: ...
        def mark(self) -> int: ...
        def sleep(self, seconds: float) -> None: ...
        @property
        def time_scale(self) -> float: ...

    profile: Optional[Profile]
    profile_exact: bool
    profile_why: str          # how the profile was chosen when the version did not name it; else ""
    in_bootloader: bool
    version_string: Optional[str]
    notes: List[str]

    def _note_answer(self, answer: Event) -> None:
        if answer.kind == "bootloader_version":
            self.in_bootloader = True
            self.version_string = str(answer.fields.get("version", ""))
            self.profile = self._requested_profile
            return
        self.in_bootloader = False
        self.version_string = str(answer.fields.get("version", ""))
        number = answer.fields.get("number")
        self.profile_why = ""
        if self._requested_profile is not None:
            self.profile, self.profile_exact = self._requested_profile, True
            if number is not None and number != self._requested_profile.number:
                self._remark(f"target reports firmware {number}, but profile {self._requested_profile} "
                             "was requested; using the requested profile")
            return
        if not isinstance(number, int):
            profile, why = _unreadable(self.version_string)
            self._remark(f"{answer.text!r}: {why}; judged as {profile}")
            self.profile, self.profile_exact, self.profile_why = profile, False, why
            return
        profile, exact = resolve_version(number)
        if not exact and (self.profile is None or self.profile.number != profile.number
                          or self.profile_exact):
            self._remark(f"unknown firmware version {number}; using the nearest earlier profile {profile}")
        self.profile, self.profile_exact = profile, exact
        if not exact:
            self.profile_why = f"unknown version {number}: {profile.name} is the nearest earlier release"

    def _remark(self, text: str) -> None:
        if text not in self.notes:
            self.notes.append(text)
            if self.transcript is not None:
                with self._cond:
                    self.transcript.note(self._transcript_t(self.now_ms()), text)

    def identify(self, timeout: float = 2.0) -> None:
        """Find out again what answers (``profile`` / ``in_bootloader`` / ``version_string``),
        e.g. after a firmware load; raises TargetError when nothing does."""
        self._splitter.forget_pending()
        self._detect(timeout)

    def reset(self, bootloader: bool = False, timeout: float = 2.0) -> List[Event]:
        """Reset the HAT through the target's control (into its bootloader if asked), then find
        out again what answers (``profile`` / ``in_bootloader``). Returns the events of the
        restart (banner, devices connecting ...) up to the detection."""
        control = self.target.control
        if control is None:
            raise NeedsCapability("reset", self.target.url)
        start = self.mark()
        with self._io_lock:
            control.reset(bootloader)
        self._splitter.forget_pending()   # whatever was typed before the reset is gone
        self._detect(timeout)
        return self.events[start:]

    def _detect(self, timeout: float) -> None:
        self.drain(quiet=0.05, limit=1.0)  # stale output cannot fool the fence: a short drain is enough
        for _attempt in range(OPEN_ATTEMPTS):
            try:
                self.fence(timeout)
                return
            except ExpectTimeout:
                continue
        finding = broken_version(bytes(self.received), OPEN_ATTEMPTS)
        if finding is not None:
            raise BrokenClause(f"{self.target.url} answers like a Build HAT but breaks the version clause: "
                               f"{finding}", "version", "CMD-VERSION", finding)
        diagnosis = self._diagnosis(timeout)
        finding = self._flood_after_reset()
        if finding is not None:
            raise BrokenClause(f"{self.target.url} answers like a Build HAT but floods: {finding}",
                               "", "PWR-PORT-FAULT", finding)
        raise TargetError(diagnosis)

    def _flood_after_reset(self) -> Optional[str]:
        """A target that floods printable text and can be reset: reset it once and judge its
        start-up (harness/hat_evidence.py). None when that shows no Build HAT."""
        control = getattr(self.target, "control", None)
        data = bytes(self.received)
        if control is None or len(data) < 4096 or \
                sum(1 for b in data if 0x20 <= b < 0x7F or b in (0x0D, 0x0A)) < 0.9 * len(data):
            return None      # silence, a few lines or garbage: not a flood to look into
        start, reset_ms = self.mark(), self.now_ms()
        try:
            with self._io_lock:
                control.reset(False)
        except (TargetError, NeedsCapability, ValueError):
            return None
        self._splitter.forget_pending()
        self.sleep(FLOOD_WINDOW_MS / 1000.0 / self.time_scale)
        return power_fault_flood(self.events[start:], reset_ms, time_scale=self.time_scale)

    def _diagnosis(self, timeout: float) -> str:
        url, data = self.target.url, bytes(self.received)
        asked = f"sent `version` {OPEN_ATTEMPTS} times, {timeout:g} s each"
        if not data:
            hint = self.target.diagnose("silent")
            return f"nothing answering on {url}: {asked}, and not one byte came back." + \
                (f"\n{hint}" if hint else "")
        printable = sum(1 for b in data if 0x20 <= b < 0x7F or b in (0x0D, 0x0A))
        if printable < 0.9 * len(data):
            hint = self.target.diagnose("garbage")
            return (f"{url} answers with garbage, not the Build HAT's text: {asked}; received "
                    f"{len(data)} bytes, {len(data) - printable} of them not printable "
                    f"(first bytes: {data[:24].hex(' ')})." + (f"\n{hint}" if hint else ""))
        return (f"{url} answers, but not like a Build HAT (no 'Firmware version:' or "
                f"'BuildHAT bootloader version' line): {asked}; "
                f"{describe_events(self.events[:], self.partial, limit=10)}")
