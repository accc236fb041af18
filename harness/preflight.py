"""Check a target before anything runs on it, and say what is wrong in one line.

One function for every sub-command (``run``, ``script``, ``fuzz``, ``record``, ``replay``):
:func:`checked_target` turns a URL into a target, raising :class:`UsageError` for what the
user typed wrong (an unknown kind of target, a bad option, an unknown release) and
:class:`TargetError` for what cannot be reached (no such device, not a serial port, nothing
listening); :func:`check_answers` then opens it and asks ``version``, so a silent or garbled
target is one line too, before a single case runs.
"""
from __future__ import annotations

import os
import shutil
import stat
from typing import Optional

from ..plumbing.cli_options import UsageError
from ..protocol.profiles import Profile, get_profile
from .errors import BrokenClause
from .targets import make_target
from .targets.base import NeedsCapability, Target, TargetError

__all__ = ["checked_target", "check_release", "check_answers", "one_line", "Answer"]

_HINT_TARGETS = "'buildhat-conformance targets' lists what this machine can reach"


def one_line(message: object, limit: int = 600) -> str:
    """A message on one line: its lines joined with '; ', spaces collapsed."""
    parts = [" ".join(line.split()) for line in str(message).splitlines()]
    text = "; ".join(p for p in parts if p)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def check_release(spec: str, what: str) -> Profile:
    """The profile for a release spec the user gave; UsageError (with the known ones) if unknown."""
    try:
        return get_profile(spec)
    except KeyError as exc:
        raise UsageError(f"{what}: {exc.args[0]}") from None


def _scheme(url: str) -> str:
    return url.split(":", 1)[0].split("?", 1)[0].lower()


def _check_device_path(path: str, target: Target) -> None:
    """A local path must exist and be a character device that is a terminal (a UART)."""
    if not os.path.exists(path):
        missing = getattr(target, "_missing", None)   # the serial target's own advice (ports seen)
        raise TargetError(one_line(missing()) if callable(missing)
                          else f"no such device: {path}; {_HINT_TARGETS}")
    mode = os.stat(path).st_mode
    if not stat.S_ISCHR(mode):
        raise TargetError(f"{path} is not a serial device (not a character device); {_HINT_TARGETS}")
    try:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except PermissionError:
        raise TargetError(f"{path}: permission denied; add yourself to the 'dialout' group "
                          "(sudo usermod -aG dialout $USER, then log in again)") from None
    except OSError as exc:
        raise TargetError(f"cannot open {path}: {exc.strerror}") from None
    try:
        if not os.isatty(fd):
            raise TargetError(f"{path} is not a serial device (not a terminal); {_HINT_TARGETS}")
    finally:
        os.close(fd)


def checked_target(url: str, layout: Optional[dict] = None, **options) -> Target:
    """The target for ``url`` (not opened), after the checks that need no traffic.
    ``layout`` (a scenario's start-up devices): an emulator target whose URL names no
    ``device=`` is started with it; other targets are left as they are (the runner checks)."""
    if layout and _scheme(url) in ("emulator", "inprocess", "sil") and "device=" not in url:
        options["devices"] = dict(layout)
    try:
        target = make_target(url, **options)
    except NeedsCapability:
        raise
    except TargetError as exc:
        raise UsageError(one_line(exc)) from None
    scheme = _scheme(url)
    if scheme in ("emulator", "inprocess"):
        release = getattr(target, "firmware", None)
        if release not in (None, ""):
            check_release(str(release), f"target {url}")
    path = getattr(target, "path", None)
    if isinstance(path, str) and path.startswith("/"):
        _check_device_path(path, target)
    if scheme == "cmd":
        argv = getattr(target, "argv", None) or []
        runnable = argv and (os.access(argv[0], os.X_OK) if os.path.sep in argv[0] else shutil.which(argv[0]))
        if argv and not runnable:
            raise TargetError(f"{url}: command not found: {argv[0]!r}")
    return target


class Answer:
    """What answered at open: the firmware's version string, or the bootloader."""

    def __init__(self, version_string: str, in_bootloader: bool, notes: list):
        self.version_string = version_string
        self.in_bootloader = in_bootloader
        self.notes = notes


def check_answers(target: Target, timeout: float = 2.0, profile: Optional[Profile] = None) -> Answer:
    """Open the target, ask ``version`` (the session's own detection), close it. Raises
    TargetError, on one line, when it cannot be opened or nothing answers like a HAT."""
    from .session import Session

    session = Session(target, transcript=None, profile=profile)
    try:
        session.open(timeout=timeout)
        return Answer(session.version_string or "", bool(session.in_bootloader), list(session.notes))
    except BrokenClause:
        raise        # a Build HAT breaking a clause: `run` reports it as a failure, the rest refuse
    except TargetError as exc:
        raise TargetError(one_line(exc)) from None
    finally:
        session.close()
