"""The firmware's command-line tokenizer and number parsers (FIRMWARE-BEHAVIOUR.md#fb-matching,
#fb-arguments).

A :class:`Cursor` walks over the bytes of one line. NUL ends the line (everything after it
is invisible). Command functions read their arguments with the methods below and raise
:class:`CommandError` (the firmware prints ``Error`` and drops the rest of the line).

Methods (all return the value and advance; on failure they raise ``CommandError`` and
leave the position where the token started):

- ``match(names)``: the command/sub-keyword matcher (#fb-matching). First name in ``names`` that the
  token is a non-empty prefix of; the token ends at space, ``;`` or end of line. One
  separator byte after the token is consumed, then spaces. Returns ``None`` (and consumes
  nothing) when no name matches.
- ``unsigned()``: digits only, wraps modulo 2^32.
- ``signed()``: optional single ``+``/``-`` then digits; 32-bit two's complement result.
- ``float()``: optional sign, ``d``, ``d.``, ``.d``, ``d.d``; no exponent; 9-digit
  accumulator; result rounded to single precision (``-0`` gives -0.0).
- ``hex32()`` / ``hexbyte()``: one or more hex digits, value mod 2^32 / its low 8 bits.
- ``format()``: exactly two characters among ``u1 s1 u2 s2 u4 s4 f4`` (what follows is not
  checked); returns the internal code (size | 0x100 signed | 0x200 float).
- ``try_<kind>()``: the same, but returns ``None`` instead of raising (position unchanged).
- ``at_end()``, ``peek()``, ``skip_spaces()``, ``skip_separators()``, ``rest()``.
- ``next_command(prefixes)``: the dispatcher's step: separators, then the token and the
  command it names (``prefixes`` from :func:`prefix_table`).

Every number parser skips the *spaces* (not ``;``) after its token, as the firmware does.
"""
from __future__ import annotations

import re
from functools import lru_cache
from typing import Dict, Optional, Sequence, Tuple, TypeVar

from ..f32 import f32

__all__ = ["Cursor", "CommandError", "FORMAT_CODES", "prefix_table", "format_size", "format_is_signed",
           "format_is_float"]

T = TypeVar("T")

SPACE = 0x20
SEMI = 0x3B

# Internal codes of the value formats (``u1`` ... ``f4``, #fb-numbers): size in the low nibble,
# 0x100 = signed, 0x200 = float.
FORMAT_CODES = {b"u1": 0x001, b"s1": 0x101, b"u2": 0x002, b"s2": 0x102,
                b"u4": 0x004, b"s4": 0x104, b"f4": 0x204}

# Digits go into the integer accumulator only while it is below this (at most 9 digits).
_ACC_LIMIT = 100000000
_MASK32 = 0xFFFFFFFF

# Runs found with one regex call instead of a Python loop per byte (H10 profile: the parser's
# per-byte peeks were a large part of what a fuzzed line costs the emulator). All but _FORMAT
# also match the empty string, so their ``match`` never fails (the ``assert m`` narrowings).
_SPACES = re.compile(rb" *")
_SEPARATORS = re.compile(rb"[ ;]*")
_TOKEN = re.compile(rb"[^ ;]*")
# A number and the spaces after it (every number parser skips them).
_UNSIGNED = re.compile(rb"([0-9]*) *")
_HEX = re.compile(rb"([0-9a-fA-F]*) *")
_SIGNED = re.compile(rb"([+-]?)([0-9]*) *")
_FLOAT = re.compile(rb"([+-]?)([0-9]*)(?:\.([0-9]*))? *")
_FORMAT = re.compile(rb"(u1|s1|u2|s2|u4|s4|f4) *")   # two characters; what follows is not checked
_COMMAND = re.compile(rb"[ ;]*([^ ;]*)(?:[ ;] *)?")   # separators, a token, one separator, spaces


_POWERS10 = [1.0]


def _f32_power10(n: int) -> float:
    """10^n as the float parser builds it: ``n`` float32 multiplications by 10 (exact up to
    10^10, rounded after that), kept in a table so a look-up replaces the loop."""
    while len(_POWERS10) <= n:
        _POWERS10.append(f32(_POWERS10[-1] * 10.0))
    return _POWERS10[n]


def _accumulate(whole: bytes, fraction: bytes) -> Tuple[int, int, int]:
    """The float parser's 32-bit digit accumulator (#fb-numbers) over the digits before and after the
    point: (accumulator, integer digits that did not fit, fraction digits kept)."""
    if len(whole) + len(fraction) <= 9:
        return int(whole + fraction), 0, len(fraction)   # nine digits always fit
    acc = overflow = frac = 0
    for c in whole:
        if acc < _ACC_LIMIT:
            acc = acc * 10 + c - 0x30
        else:
            overflow += 1
    for c in fraction:
        if acc < _ACC_LIMIT:
            acc = acc * 10 + c - 0x30
            frac += 1
    return acc, overflow, frac


@lru_cache(maxsize=64)
def prefix_table(names: Tuple[str, ...]) -> Dict[bytes, str]:
    """Every non-empty prefix of every name -> the first name (in matching order) it starts.
    Built once per name list, so matching a token is one dict lookup (#fb-matching's rule unchanged)."""
    table: Dict[bytes, str] = {}
    for name in names:
        encoded = name.encode("ascii")
        for end in range(1, len(encoded) + 1):
            table.setdefault(encoded[:end], name)
    return table


class CommandError(Exception):
    """A command failed: the firmware prints ``Error`` and ignores the rest of the line."""


def format_size(code: int) -> int:
    return code & 0x0F


def format_is_signed(code: int) -> bool:
    return bool(code & 0x100)


def format_is_float(code: int) -> bool:
    return bool(code & 0x200)


class Cursor:
    """A read position in one received line (NUL-terminated like the firmware's buffer)."""

    __slots__ = ("data", "pos")

    def __init__(self, line: bytes, pos: int = 0):
        nul = line.find(b"\x00")
        self.data = bytes(line if nul < 0 else line[:nul])
        self.pos = pos

    def __repr__(self) -> str:
        return f"Cursor({self.data[:self.pos]!r} | {self.data[self.pos:]!r})"

    # -- position ------------------------------------------------------------------------
    def peek(self) -> Optional[int]:
        """The next byte, or None at the end of the line."""
        return self.data[self.pos] if self.pos < len(self.data) else None

    def at_end(self) -> bool:
        return self.pos >= len(self.data)

    def rest(self) -> bytes:
        return self.data[self.pos:]

    def skip_spaces(self) -> None:
        m = _SPACES.match(self.data, self.pos)
        assert m is not None
        self.pos = m.end()

    def skip_separators(self) -> None:
        """Skip a run of spaces and ``;`` (what separates commands)."""
        m = _SEPARATORS.match(self.data, self.pos)
        assert m is not None
        self.pos = m.end()

    def token(self) -> bytes:
        """The bytes up to the next space, ``;`` or end (not consumed)."""
        m = _TOKEN.match(self.data, self.pos)
        assert m is not None
        return m.group()

    # -- matcher -------------------------------------------------------------------------
    def match(self, names: Sequence[str]) -> Optional[str]:
        """First of ``names`` that the next token is a non-empty prefix of (#fb-matching), or None."""
        tok = self.token()
        name = prefix_table(tuple(names)).get(tok) if tok else None
        if name is None:
            return None
        self.pos += len(tok)
        if self.pos < len(self.data):   # the token ended at a separator: take it, then spaces
            self.pos += 1
        self.skip_spaces()
        return name

    def next_command(self, prefixes: Dict[bytes, str]) -> Tuple[bytes, Optional[str]]:
        """Skip separators, then (token, the command it names or None); the token is empty at
        the end of the line. A named command is consumed like :meth:`match`; an unknown token
        is left in place. One regex call: this runs for every command of every line."""
        m = _COMMAND.match(self.data, self.pos)
        assert m is not None
        tok = m.group(1)
        name = prefixes.get(tok) if tok else None
        self.pos = m.end() if name is not None else m.start(1)
        return tok, name

    # -- numbers -------------------------------------------------------------------------
    # The ``_scan_*`` parsers return None (position unchanged) when no number starts here; the
    # public ones raise. Failing without an exception matters: ``select``/``combi``/``write``
    # probe for optional numbers on every argument.
    def _scan_unsigned(self) -> Optional[int]:
        m = _UNSIGNED.match(self.data, self.pos)
        assert m is not None
        digits = m.group(1)
        if not digits:
            return None
        self.pos = m.end()
        return int(digits) & _MASK32             # the firmware's accumulator wraps mod 2^32

    def _scan_signed(self) -> Optional[int]:
        m = _SIGNED.match(self.data, self.pos)
        assert m is not None
        sign, digits = m.groups()
        if not digits:
            return None
        value = int(digits) & _MASK32
        if sign == b"-":
            value = (-value) & _MASK32
        self.pos = m.end()
        return value - (1 << 32) if value & 0x80000000 else value

    def _scan_float(self) -> Optional[float]:
        m = _FLOAT.match(self.data, self.pos)
        assert m is not None
        sign, whole, fraction = m.groups()
        if not whole and not fraction:
            return None
        acc, overflow, frac = _accumulate(whole, fraction or b"")
        scale = _f32_power10(overflow)     # x10 (float) for every integer digit that did not fit
        value = f32(f32(float(acc)) * (-scale if sign == b"-" else scale))
        self.pos = m.end()
        return f32(value / _f32_power10(frac))

    def _scan_hex32(self) -> Optional[int]:
        m = _HEX.match(self.data, self.pos)
        assert m is not None
        digits = m.group(1)
        if not digits:
            return None
        self.pos = m.end()
        return int(digits, 16) & _MASK32

    def _scan_hexbyte(self) -> Optional[int]:
        value = self._scan_hex32()
        return None if value is None else value & 0xFF

    def _scan_format(self) -> Optional[int]:
        m = _FORMAT.match(self.data, self.pos)
        if m is None:
            return None
        self.pos = m.end()
        return FORMAT_CODES[m.group(1)]

    def _need(self, value: Optional[T], what: str) -> T:
        if value is None:
            raise CommandError(f"expected {what} at {self.data[self.pos:self.pos + 12]!r}")
        return value

    def unsigned(self) -> int:
        return self._need(self._scan_unsigned(), "an unsigned number")

    def signed(self) -> int:
        return self._need(self._scan_signed(), "a signed number")

    def float(self) -> float:
        return self._need(self._scan_float(), "a number")

    def hex32(self) -> int:
        return self._need(self._scan_hex32(), "hex digits")

    def hexbyte(self) -> int:
        return self._need(self._scan_hexbyte(), "hex digits")

    def format(self) -> int:
        return self._need(self._scan_format(), "a format (u1 s1 u2 s2 u4 s4 f4)")

    # -- optional forms ------------------------------------------------------------------
    try_unsigned = _scan_unsigned
    try_signed = _scan_signed
    try_float = _scan_float
    try_hex32 = _scan_hex32
    try_hexbyte = _scan_hexbyte
    try_format = _scan_format
