"""Which release a fuzz target runs, and whether it is the one it is judged by.

The fuzzer's fences and every prediction carry one release's words (its `version` line, command
table, help text). A target that answers as another release than ``--firmware`` names would fail
every fence: the campaign would send nothing and judge nothing. So the target's own `version` is
read first and compared; a mismatch stops the campaign before any budget is spent (exit 3).
A build between two releases is judged as the release asked for (or the nearest earlier one),
with its own `version` line as the fence.
"""
from __future__ import annotations

import dataclasses
from typing import Callable, Optional

from ..harness.targets.base import Target, TargetError
from ..protocol.profiles import Profile, get_profile, resolve_version

__all__ = ["ReleaseMismatch", "detect_profile", "judged_profile"]


class ReleaseMismatch(TargetError):
    """The target runs a known release other than the one it is to be judged by."""


def _answer(open_target: Callable[[], Target], timeout: float) -> tuple:
    """(version number or None, the text after ``Firmware version: ``), via the harness session."""
    from ..harness.session import Session
    session = Session(open_target())
    try:
        session.open(timeout=timeout)
        if session.in_bootloader:
            raise TargetError("the target is in its bootloader; the fuzzer needs the firmware running")
        if session.profile is None or not session.version_string:
            raise TargetError("the target did not say which firmware it runs (no answer to `version`)")
        number = session.version_string.split()[0]
        return (int(number) if number.isdigit() else None), session.version_string
    finally:
        session.close()


def _with_version(profile: Profile, version_string: str) -> Profile:
    # The fence waits for the target's own `version` line (an unknown build prints its own).
    if profile.version_string == version_string:
        return profile
    return dataclasses.replace(profile, version_string=version_string)


def judged_profile(open_target: Callable[[], Target], asked: Optional[str], timeout: float = 2.0,
                   what: str = "the target") -> Profile:
    """The profile to judge the target by: ``asked`` (``--firmware``) or the one its `version`
    names. Raises :class:`ReleaseMismatch` when the target runs another known release than asked."""
    number, version_string = _answer(open_target, timeout)
    if number is None:
        base = get_profile(asked)
        return _with_version(base, version_string)
    detected, exact = resolve_version(number)
    if asked is None:
        return _with_version(detected, version_string)
    wanted = get_profile(asked)
    if exact and detected.number != wanted.number:
        raise ReleaseMismatch(
            f"{what} answers as {detected} but --firmware {asked} judges it as {wanted}: every fence and "
            f"prediction would be {wanted.name}'s, so nothing could be fuzzed; drop --firmware or name "
            f"{detected.name}")
    return _with_version(wanted, version_string)


def detect_profile(open_target: Callable[[], Target], timeout: float = 2.0) -> Profile:
    """The release a target runs, from its answer to ``version`` (via the harness session)."""
    return judged_profile(open_target, None, timeout)
