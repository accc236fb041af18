"""The one small interface every target implements (cf. pyserial's transports).

A target moves bytes; it knows nothing of lines or commands (that is the session's job).
Targets that can change the world around the HAT (the emulator) also offer a
:class:`Control` with the scenario format's world actions.
"""
from __future__ import annotations

import abc
from typing import Callable, FrozenSet, List, Optional

__all__ = ["Target", "Control", "TargetError", "NeedsCapability", "NotReading", "WRITE_DEADLINE_S",
           "keeps_process_resources", "release_process_resources"]

#: How long a write may wait for the target to take the bytes. A HAT reads its UART all the time
#: (115200 baud moves a command line in milliseconds); one that has not taken a line in this
#: long has stopped reading, and waiting longer would only hang the host (issue 13).
WRITE_DEADLINE_S = 5.0


# What a kind of target keeps beyond its objects, for the whole process (sil: a booted firmware
# per layout, copied at every open): each kind registers how to release it, and a process that
# ends its work early (a fuzz worker) releases everything through this interface, knowing no kind.
_RELEASERS: List[Callable[[], None]] = []


def keeps_process_resources(release: Callable[[], None]) -> Callable[[], None]:
    """Register ``release`` (a decorator): it frees what a kind of target keeps for the process."""
    _RELEASERS.append(release)
    return release


def release_process_resources() -> None:
    """Free what every kind of target imported in this process keeps (its releasers, in order)."""
    for release in list(_RELEASERS):
        release()


class TargetError(RuntimeError):
    """A target could not be opened or used. The message says what to do about it."""


class NotReading(TargetError):
    """The target stopped reading: a write did not complete within its deadline."""


class TargetCrashed(TargetError):
    """The HAT's firmware crashed (a signal, a sanitizer report): ``report`` is all it said."""

    def __init__(self, message: str, report: str = ""):
        super().__init__(message)
        self.report = report


class NeedsCapability(TargetError):
    """The test or script needs a world action the target cannot perform."""

    def __init__(self, capability: str, target: str = "", detail: str = ""):
        self.capability = capability
        if not detail and target:
            detail = f"target {target} has no such control"
        super().__init__(f"needs {capability}" + (f" ({detail})" if detail else ""))


class Control(abc.ABC):
    """Out-of-band control of the world around the HAT (never in-band on the command port).

    ``capabilities`` names what it can do: the scenario-script world actions (``plug``,
    ``unplug``, ``data``, ``motorfault``, ``portfault``, ``button``, ``adc``, ``rate``,
    ``hold``, ``pos``) plus ``reset`` and ``bootloader``; ``faultpulse``: ``@portfault 1 MS``
    holds the port fault for MS ms of the HAT's time (a rig timing it by the wall clock cannot).
    """

    capabilities: FrozenSet[str] = frozenset()

    @abc.abstractmethod
    def action(self, line: str) -> str:
        """Perform one world action written as a script line, e.g. ``@plug 1 0x30``.
        Returns the reply text; raises TargetError when the action failed."""

    @property
    def time_scale(self) -> float:
        """How many times faster than real time the target runs (1.0 for hardware)."""
        return 1.0

    def reset(self, bootloader: bool = False) -> None:
        """Reset the HAT (into its bootloader if asked), as the host's reset GPIO would."""
        raise NeedsCapability("reset")


class Target(abc.ABC):
    """A HAT (or something pretending to be one) reachable through bytes."""

    url: str = ""
    #: What this target can do beyond bytes, e.g. {"control", "plug", ...}.
    capabilities: FrozenSet[str] = frozenset()
    control: Optional[Control] = None
    #: The HAT ends with the target (an emulator the target started itself): nothing done to
    #: the world around it needs putting back at the end of a run.
    disposable: bool = False
    #: True between a successful open() and close(); the session opens a target only if False.
    is_open: bool = False
    #: How a target of this kind gets a way to reset the HAT, for the line saying it has none.
    reset_hint: str = "on a Raspberry Pi, add ?reset=gpio to a serial target (docs/LAB.md)"

    @abc.abstractmethod
    def open(self) -> None:
        """Open the link. Raises TargetError with an actionable message on failure."""

    #: Seconds a write may wait for the target to take its bytes before it raises NotReading.
    write_deadline: float = WRITE_DEADLINE_S

    @abc.abstractmethod
    def write(self, data: bytes) -> None:
        """Send bytes exactly as given (no line-ending translation). Raises NotReading when the
        target does not take them within ``write_deadline`` seconds (never blocks longer)."""

    @abc.abstractmethod
    def read(self, timeout: float) -> bytes:
        """Bytes received so far, waiting up to ``timeout`` seconds for the first one.
        Returns b"" on timeout. Raises TargetError if the target has gone away."""

    @abc.abstractmethod
    def close(self) -> None:
        """Close the link; safe to call twice."""

    @property
    def time_scale(self) -> float:
        return self.control.time_scale if self.control else 1.0

    def diagnose(self, problem: str) -> str:
        """Advice for a problem the session found at open: ``silent`` (no byte came back)
        or ``garbage`` (bytes that are not the protocol's text). Targets override this
        with what is likely wrong for their kind of link; "" when there is nothing to add."""
        return ""

    def has(self, capability: str) -> bool:
        if capability in self.capabilities:
            return True
        return bool(self.control and capability in self.control.capabilities)

    def require(self, capability: str) -> None:
        if not self.has(capability):
            raise NeedsCapability(capability, self.url)

    def __enter__(self) -> Target:
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.url}>"
