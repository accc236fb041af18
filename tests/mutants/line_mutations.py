"""The named mutations of a mutant HAT: ONE behaviour of the reference emulator perturbed.

Shared by the two mutant HATs: the pty relay in front of the real ``buildhat-emulator`` process
(mutant_emulator.py) and the in-process wrapper in virtual time (mutant_target.py). Each works on
complete output lines (a function returning the new line, or None to drop it) or on the host's
bytes before the firmware sees them (``lf-ignored``, ``prefix-last-match``).
"""
from __future__ import annotations

import re
from typing import Callable, Dict, Optional, Tuple

from buildhat_conformance.protocol.profiles import get_profile

__all__ = ["MUTATIONS", "Mutation"]


def _vin_plus_one(line: bytes) -> bytes:
    m = re.fullmatch(rb"([0-9]+)\.([0-9]{2}) V", line)
    if not m:
        return line
    k = int(m.group(1)) * 100 + int(m.group(2)) + 1
    return f"{k // 100}.{k % 100:02d} V".encode()


def _unknown_version(line: bytes) -> bytes:
    # A release no profile knows, later than every known one: judged as the nearest earlier.
    if line.startswith(b"Firmware version: "):
        return b"Firmware version: 1740000000 2025-02-20T10:00:00+00:00"
    return line


def _no_done(line: bytes) -> Optional[bytes]:
    return None if re.fullmatch(rb"P[0-3]: (pulse|ramp) done", line) else line


class _FirstFaultOnly:
    """'Port power fault' printed once, not repeated while the fault lasts."""

    def __init__(self) -> None:
        self.seen = False

    def __call__(self, line: bytes) -> Optional[bytes]:
        if line != b"Port power fault":
            return line
        if self.seen:
            return None
        self.seen = True
        return line


def _no_error(line: bytes) -> Optional[bytes]:
    return None if line == b"Error" else line


def _symbol_space_dropped(line: bytes) -> bytes:
    return line[:-1] if re.fullmatch(rb"  M[0-9]+ .+ SI = ", line) else line


def _pid_sign_flipped(line: bytes) -> bytes:
    m = re.fullmatch(rb"(P[0-3]: pv=.* cv=)(-?)(.*)", line)
    if not m:
        return line
    return m.group(1) + (b"" if m.group(2) else b"-") + m.group(3)


def _same(line: bytes) -> bytes:
    return line


# Output mutations, made fresh per HAT (some keep state).
_LINE_MUTATIONS: Dict[str, Callable[[], Callable[[bytes], Optional[bytes]]]] = {
    "vin-off-by-one": lambda: _vin_plus_one,
    "error-swallowed": lambda: _no_error,
    "list-symbol-space-dropped": lambda: _symbol_space_dropped,
    "pid-output-sign-flipped": lambda: _pid_sign_flipped,
    "done-dropped": lambda: _no_done,
    "port-fault-not-repeated": _FirstFaultOnly,
    "none": lambda: _same,                       # a faithful relay (for the kill test)
    "unknown-version": lambda: _unknown_version,  # not a fault: a newer release (profile fallback)
}
_INPUT_MUTATIONS = ("lf-ignored", "prefix-last-match")
MUTATIONS: Tuple[str, ...] = tuple(sorted(set(_LINE_MUTATIONS) | set(_INPUT_MUTATIONS)))


class Mutation:
    """One named mutation: :meth:`host` rewrites what the host sends, :meth:`line` each output line."""

    def __init__(self, name: str, firmware: Optional[str] = None):
        if name not in MUTATIONS:
            raise ValueError(f"unknown mutation {name!r}; known: {', '.join(MUTATIONS)}")
        self.name = name
        self._line = _LINE_MUTATIONS.get(name, lambda: _same)()
        self._table = get_profile(firmware).commands if name == "prefix-last-match" else ()
        self._pending = b""          # host bytes since the last CR (prefix-last-match)

    def line(self, line: bytes) -> Optional[bytes]:
        """An output line (without CRLF) as the mutant prints it; None: not printed."""
        return self._line(line)

    def host(self, data: bytes) -> bytes:
        """Host bytes as the mutant's firmware receives them (a partial line may be held back)."""
        if self.name == "lf-ignored":
            return data.replace(b"\n", b"")
        if self.name != "prefix-last-match":
            return data
        self._pending += data
        out = b""
        while b"\r" in self._pending:
            line, self._pending = self._pending.split(b"\r", 1)
            out += self._last_match(line) + b"\r"
        return out

    def _last_match(self, line: bytes) -> bytes:
        """An ambiguous prefix typed as a command means the LAST command it prefixes (the table
        order reversed), by spelling that command out in full."""
        def first_word(segment: str) -> str:
            words = segment.split(" ")
            for i, w in enumerate(words):
                if w:
                    names = [c for c in self._table if c.startswith(w)]
                    if len(names) > 1 and w not in self._table:
                        words[i] = names[-1]
                    break
            return " ".join(words)
        text = line.decode("latin-1")
        return ";".join(first_word(seg) for seg in text.split(";")).encode("latin-1")
