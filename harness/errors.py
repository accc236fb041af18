"""Exceptions of the harness. Target problems are :class:`TargetError` (harness/targets/base.py)."""
from __future__ import annotations

from typing import Optional

from .targets.base import NeedsCapability, NotReading, TargetCrashed, TargetError

__all__ = ["TargetError", "TargetCrashed", "NeedsCapability", "NotReading", "SessionError", "ExpectTimeout",
           "BrokenClause"]


class SessionError(RuntimeError):
    """The session could not do what was asked (not a target fault)."""


class ExpectTimeout(SessionError, AssertionError):
    """An expected event did not arrive in time. An AssertionError too, so that pytest
    reports a missing answer as a test failure rather than an infrastructure error."""

    def __init__(self, message: str, arrived: Optional[list] = None, partial: bytes = b""):
        self.arrived = list(arrived or [])
        self.partial = partial
        super().__init__(message)


class BrokenClause(TargetError):
    """The target is a Build HAT, but it breaks a clause the session needs before any case
    (harness/hat_evidence.py): a conformance run reports it as that clause's failure; every other
    command cannot do its job with it (a TargetError, exit 3)."""

    def __init__(self, message: str, clause: str, requirement: str, finding: str):
        self.clause, self.requirement, self.finding = clause, requirement, finding
        super().__init__(message)
