"""Once per run: reset a HAT that stopped answering, and go on if it comes back.

After ``--max-target-faults`` target faults in a row the run would stop talking to the target.
When the target can reset the HAT (the emulator's control channel, or ``?reset=gpio`` on a
Raspberry Pi) the run first resets it, once:

- a real HAT restarts in its bootloader (its firmware lives in RAM,
  docs/FIRMWARE-BEHAVIOUR.md#fb-bootloader), so the release is loaded again from the run's
  ``--image``/``--signature``; without them the reset cannot bring the firmware back, and the run
  says so in one line;
- the emulator restarts its firmware, or its bootloader when the run has an image to load.

The HAT must then answer ``version`` with the firmware it ran before; the next case's set-up
restores the suite's preconditions as after any restart (conformance/resync.py). Whatever
happens, one line says it (JUnit property ``reset``, the terminal summary).
"""
from __future__ import annotations

import io
from typing import Any, Optional

from ...harness.errors import ExpectTimeout, TargetError
from ..target_fault import first_line

__all__ = ["ResetRecovery", "RecoveryFailed"]

#: Seconds the HAT has to answer ``version`` after a reset (a real HAT's bootloader starts in
#: ~0.5 s, the firmware's start-up prints for ~1.5 s before it answers promptly).
ANSWER_S = 3.0


class RecoveryFailed(Exception):
    """The reset did not bring the HAT back (one line: what happened)."""


class ResetRecovery:
    """The run's one reset. ``image``/``signature``: the release to load after it, if any."""

    def __init__(self, image: Optional[str] = None, signature: Optional[str] = None):
        self.image, self.signature = image, signature
        self.outcome: Optional[str] = None        # one line, once the reset was tried

    def why_not(self, target: Any) -> Optional[str]:
        """Why the run cannot (or no longer may) reset ``target``; None when it can."""
        from ...harness.bootloader.load import can_reset

        if self.outcome is not None:
            return "the run's one reset was used already"
        if getattr(target, "dead", None):
            return "the target went away"
        if not can_reset(target):
            return f"{target.url} cannot reset the HAT ({target.reset_hint})"
        return None

    def attempt(self, session: Any) -> str:
        """Reset the HAT behind ``session``, reload the release if it is in its bootloader, and
        check it runs what it ran before. Returns one line; raises RecoveryFailed."""
        before = session.version_string
        reload = bool(self.image and self.signature)
        try:
            self._attempt(session, before, reload)
        except RecoveryFailed as exc:
            self.outcome = f"reset the HAT once, in vain: {exc}"
            raise RecoveryFailed(self.outcome) from None
        self.outcome = ("reset the HAT once" + (f" and loaded {self.image} again" if reload else "")
                        + f"; it answers again ({session.version_string})")
        return self.outcome

    def _attempt(self, session: Any, before: Optional[str], reload: bool) -> None:
        try:
            session.reset(bootloader=reload, timeout=ANSWER_S)
        except (TargetError, ExpectTimeout) as exc:
            raise RecoveryFailed(f"nothing answered after it ({first_line(str(exc))})") from None
        if session.in_bootloader:
            if not reload:
                raise RecoveryFailed(f"the HAT is in its bootloader ({session.version_string}) and the run "
                                     "has no --image/--signature to load the release again")
            self._load(session)
        if session.version_string != before:
            raise RecoveryFailed(f"the HAT runs {session.version_string!r} now, not {before!r}")

    def _load(self, session: Any) -> None:
        from ...harness.bootloader.errors import LoadError
        from ...harness.bootloader.image import read_firmware
        from ...harness.bootloader.load import load_firmware
        from ...harness.bootloader.session_stream import SessionStream

        assert self.image is not None and self.signature is not None
        try:
            # No progress bar: the suite's terminal output is pytest's.
            load_firmware(SessionStream(session), read_firmware(self.image, self.signature),
                          progress_stream=io.StringIO(), tty=False)
            session.identify(ANSWER_S)
        except LoadError as exc:
            raise RecoveryFailed(f"loading {self.image} failed: {exc}") from None
        except (TargetError, ExpectTimeout) as exc:
            raise RecoveryFailed(f"nothing answered after loading {self.image} "
                                 f"({first_line(str(exc))})") from None
