"""Which release a fuzz target runs, and whether it is the one it is judged by.

The fuzzer's fences and every prediction carry one release's words (its `version` line, command
table, help text). A target that answers as another release than ``--firmware`` names would fail
every fence: the campaign would send nothing and judge nothing. So the target's own `version` is
read first and compared; a mismatch stops the campaign before any budget is spent (exit 3).
A build no profile knows is judged as the release asked for (or the nearest earlier one), with its
own `version` line as the fence. What belongs to one build only is not predicted from another: its
signature (one image's) and its help text (which any build may change) are the build's own first
answers, and the campaign checks that it keeps giving them. A build described in a ``--profiles``
file (docs/PROFILES.md) is a known one, judged by all its file says.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Callable, List, NamedTuple, Optional, Tuple

from ...harness.targets.base import Target, TargetError
from ...protocol.profiles import Profile, get_profile, load_profiles, resolve_version

__all__ = ["ReleaseMismatch", "detect_profile", "judged_profile", "judged_note", "against_release"]


class ReleaseMismatch(TargetError):
    """The target runs a known release other than the one it is to be judged by."""


class Identity(NamedTuple):
    """What a target says about itself: its version number (None when unreadable), the text after
    ``Firmware version: ``, and for a build no profile knows, its own help text and signature."""

    number: Optional[int]
    version_string: str
    help_lines: Optional[Tuple[str, ...]] = None
    signature: Optional[bytes] = None

    @property
    def known(self) -> bool:
        return self.number is not None and self.number in load_profiles()


def _own_words(session: Any, command: str, timeout: float) -> List[Any]:
    """The lines ``command`` printed (up to the fence's answer), unasked lines left out."""
    from ...harness.events import UNASKED_KINDS
    start = session.mark()
    session.send(command)
    session.fence(timeout)
    lines = []
    for event in session.events[start:]:
        if event.kind in ("version", "bootloader_version"):
            break
        if event.kind not in UNASKED_KINDS and event.kind not in ("echo", "prompt"):
            lines.append(event)
    # With echo off, its own CR's CRLF comes first and the fence's last: neither is its answer.
    if lines and lines[0].kind == "blank":
        lines = lines[1:]
    return lines[:-1] if lines and lines[-1].kind == "blank" else lines


def _answer(open_target: Callable[[], Target], timeout: float) -> Identity:
    """What the target says about itself, via the harness session."""
    from ...harness.session import Session
    session = Session(open_target())
    try:
        session.open(timeout=timeout)
        if session.in_bootloader:
            raise TargetError("the target is in its bootloader; the fuzzer needs the firmware running")
        if session.profile is None or not session.version_string:
            raise TargetError("the target did not say which firmware it runs (no answer to `version`)")
        head = session.version_string.split()[0]
        who = Identity(int(head) if head.isdigit() else None, session.version_string)
        if who.known:
            return who
        # The help text takes 0.4 s of a 115200-baud wire: more than a fuzzing fence waits.
        slow = max(timeout, 2.0)
        helps = tuple(e.text for e in _own_words(session, "help", slow))
        signed = [e for e in _own_words(session, "signature", slow) if e.kind == "signature"]
        signature = bytes.fromhex(signed[0].text.split(":", 1)[1]) if signed else None
        return who._replace(help_lines=helps or None, signature=signature)
    finally:
        session.close()


def _with_version(profile: Profile, who: Identity) -> Profile:
    # The fence waits for the target's own `version` line (an unknown build prints its own).
    if not who.known:
        # Another build's signature or help text would be a false `fate` finding on every run.
        return dataclasses.replace(profile, version_string=who.version_string, signature=who.signature,
                                   help_lines=who.help_lines or profile.help_lines)
    if profile.version_string == who.version_string:
        return profile
    return dataclasses.replace(profile, version_string=who.version_string)


def judged_profile(open_target: Callable[[], Target], asked: Optional[str], timeout: float = 2.0,
                   what: str = "the target") -> Profile:
    """The profile to judge the target by: ``asked`` (``--firmware``) or the one its `version`
    names. Raises :class:`ReleaseMismatch` when the target runs another known release than asked."""
    who = _answer(open_target, timeout)
    number = who.number
    if number is None:
        return _with_version(get_profile(asked), who)
    detected, exact = resolve_version(number)
    if asked is None:
        return _with_version(detected, who)
    wanted = get_profile(asked)
    if exact and detected.number != wanted.number:
        raise ReleaseMismatch(
            f"{what} answers as {detected} but --firmware {asked} judges it as {wanted}: every fence and "
            f"prediction would be {wanted.name}'s, so nothing could be fuzzed; drop --firmware or name "
            f"{detected.name}")
    return _with_version(wanted, who)


def detect_profile(open_target: Callable[[], Target], timeout: float = 2.0) -> Profile:
    """The release a target runs, from its answer to ``version`` (via the harness session)."""
    return judged_profile(open_target, None, timeout)


def judged_note(profile: Profile) -> Optional[str]:
    """One line for a build the profiles do not know (its `version` names no profile): which
    release judges it, and that its own help text and signature are expected. None otherwise."""
    head = profile.version_string.split()[:1]
    if head and head[0] == str(profile.number):
        return None
    build = f"firmware {head[0]}" if head and head[0].isdigit() else \
        f"a version line with no number ({profile.version_string!r})"
    return (f"{build} is no release the profiles know: judged as {profile.name}, with its own help text and "
            "signature (--profiles FILE describes a build, docs/PROFILES.md)")


def against_release(url: str, profile: Profile) -> Tuple[str, Optional[str]]:
    """``--against URL`` as the campaign opens it: an emulator that names no release (``emulator``,
    ``inprocess``, ``emulator:?speed=10``) runs the release the target reports, ``profile`` (or
    the nearest one the profiles know, for a build they do not), and one line says so. Any other
    URL, or one that names its release, is kept as given (with no line)."""
    scheme, colon, rest = url.partition(":")
    release, question, query = rest.partition("?")
    if scheme not in ("emulator", "inprocess") or release:
        return url, None
    new = f"{scheme}:{profile.name}" + (f"?{query}" if question else "")
    head = profile.version_string.split()[:1]
    if head and head[0] == str(profile.number):
        why = f"the release the target reports ({profile.number})"
    elif head and head[0].isdigit():
        why = f"the nearest earlier release the profiles know: the target reports {head[0]}"
    else:
        why = f"the target's version line gives no number ({profile.version_string!r})"
    return new, f"--against {url} runs as {profile.name}: {why}"
