"""Exceptions of the harness. Target problems are :class:`TargetError` (harness/targets/base.py)."""
from __future__ import annotations

from typing import Optional

from .targets.base import NeedsCapability, NotReading, TargetCrashed, TargetError

__all__ = ["TargetError", "TargetCrashed", "NeedsCapability", "NotReading", "SessionError", "ExpectTimeout"]


class SessionError(RuntimeError):
    """The session could not do what was asked (not a target fault)."""


class ExpectTimeout(SessionError, AssertionError):
    """An expected event did not arrive in time. An AssertionError too, so that pytest
    reports a missing answer as a test failure rather than an infrastructure error."""

    def __init__(self, message: str, arrived: Optional[list] = None, partial: bytes = b""):
        self.arrived = list(arrived or [])
        self.partial = partial
        super().__init__(message)
