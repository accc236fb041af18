"""The firmware's command-line tokenizer and number parsers (FIRMWARE-FACTS §2, §3).

A :class:`Cursor` walks over the bytes of one line. NUL ends the line (everything after it
is invisible). Command functions read their arguments with the methods below and raise
:class:`CommandError` (the firmware prints ``Error`` and drops the rest of the line).

Methods (all return the value and advance; on failure they raise ``CommandError`` and
leave the position where the token started):

- ``match(names)``: the command/sub-keyword matcher (§2). First name in ``names`` that the
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

Every number parser skips the *spaces* (not ``;``) after its token, as the firmware does.
"""
from __future__ import annotations

from typing import Callable, Optional, Sequence, TypeVar

from .f32 import f32

__all__ = ["Cursor", "CommandError", "FORMAT_CODES", "format_size", "format_is_signed",
           "format_is_float"]

T = TypeVar("T")

SPACE = 0x20
SEMI = 0x3B
_DIGITS = b"0123456789"
_HEX = b"0123456789abcdefABCDEF"

# Internal format codes (§3): size in the low nibble, 0x100 = signed, 0x200 = float.
FORMAT_CODES = {b"u1": 0x001, b"s1": 0x101, b"u2": 0x002, b"s2": 0x102,
                b"u4": 0x004, b"s4": 0x104, b"f4": 0x204}

# Digits go into the integer accumulator only while it is below this (at most 9 digits).
_ACC_LIMIT = 100000000


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
        while self.peek() == SPACE:
            self.pos += 1

    def skip_separators(self) -> None:
        """Skip a run of spaces and ``;`` (what separates commands)."""
        while self.peek() in (SPACE, SEMI):
            self.pos += 1

    def token(self) -> bytes:
        """The bytes up to the next space, ``;`` or end (not consumed)."""
        end = self.pos
        while end < len(self.data) and self.data[end] not in (SPACE, SEMI):
            end += 1
        return self.data[self.pos:end]

    # -- matcher -------------------------------------------------------------------------
    def match(self, names: Sequence[str]) -> Optional[str]:
        """First of ``names`` that the next token is a non-empty prefix of (§2), or None."""
        tok = self.token()
        if not tok:
            return None
        for name in names:
            if name.encode("ascii").startswith(tok):
                self.pos += len(tok)
                if self.peek() in (SPACE, SEMI):  # one separator, then spaces
                    self.pos += 1
                self.skip_spaces()
                return name
        return None

    # -- numbers -------------------------------------------------------------------------
    def _digits(self) -> tuple[int, int]:
        """(value mod 2^32, number of digits) of the digit run at the position."""
        value = n = 0
        while True:
            c = self.peek()
            if c is None or c not in _DIGITS:
                return value, n
            value = (value * 10 + c - 0x30) & 0xFFFFFFFF
            n += 1
            self.pos += 1

    def _fail(self, start: int, what: str) -> CommandError:
        self.pos = start
        return CommandError(f"expected {what} at {self.data[start:start + 12]!r}")

    def unsigned(self) -> int:
        start = self.pos
        value, n = self._digits()
        if n == 0:
            raise self._fail(start, "an unsigned number")
        self.skip_spaces()
        return value

    def signed(self) -> int:
        start = self.pos
        negative = False
        if self.peek() in (0x2B, 0x2D):  # '+' '-'
            negative = self.peek() == 0x2D
            self.pos += 1
        value, n = self._digits()
        if n == 0:
            raise self._fail(start, "a signed number")
        if negative:
            value = (-value) & 0xFFFFFFFF
        self.skip_spaces()
        return value - (1 << 32) if value & 0x80000000 else value

    def float(self) -> float:
        start = self.pos
        negative = False
        if self.peek() in (0x2B, 0x2D):
            negative = self.peek() == 0x2D
            self.pos += 1
        acc = 0          # the 32-bit digit accumulator
        scale = 1.0      # float: x10 for every integer digit that did not fit
        frac = 0         # fraction digits kept (leading zeros included)
        seen = False
        while self.peek() is not None and self.peek() in _DIGITS:
            seen = True
            if acc < _ACC_LIMIT:
                acc = acc * 10 + self.data[self.pos] - 0x30
            else:
                scale = f32(scale * 10.0)
            self.pos += 1
        if self.peek() == 0x2E:  # '.'
            self.pos += 1
            while self.peek() is not None and self.peek() in _DIGITS:
                seen = True
                if acc < _ACC_LIMIT:
                    acc = acc * 10 + self.data[self.pos] - 0x30
                    frac += 1
                self.pos += 1
        if not seen:
            raise self._fail(start, "a number")
        divisor = 1.0
        for _ in range(frac):
            divisor = f32(divisor * 10.0)
        value = f32(f32(float(acc)) * (-scale if negative else scale))
        self.skip_spaces()
        return f32(value / divisor)

    def hex32(self) -> int:
        start = self.pos
        value = n = 0
        while self.peek() is not None and self.peek() in _HEX:
            value = ((value << 4) | int(chr(self.data[self.pos]), 16)) & 0xFFFFFFFF
            n += 1
            self.pos += 1
        if n == 0:
            raise self._fail(start, "hex digits")
        self.skip_spaces()
        return value

    def hexbyte(self) -> int:
        return self.hex32() & 0xFF

    def format(self) -> int:
        code = FORMAT_CODES.get(self.data[self.pos:self.pos + 2])
        if code is None:
            raise self._fail(self.pos, "a format (u1 s1 u2 s2 u4 s4 f4)")
        self.pos += 2
        self.skip_spaces()
        return code

    # -- optional forms ------------------------------------------------------------------
    def _try(self, parse: Callable[[], T]) -> Optional[T]:
        try:
            return parse()
        except CommandError:
            return None

    def try_unsigned(self) -> Optional[int]:
        return self._try(self.unsigned)

    def try_signed(self) -> Optional[int]:
        return self._try(self.signed)

    def try_float(self) -> Optional[float]:
        return self._try(self.float)

    def try_hex32(self) -> Optional[int]:
        return self._try(self.hex32)

    def try_hexbyte(self) -> Optional[int]:
        return self._try(self.hexbyte)

    def try_format(self) -> Optional[int]:
        return self._try(self.format)
