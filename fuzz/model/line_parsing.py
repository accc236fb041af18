"""The firmware's line parsing as docs/FIRMWARE-BEHAVIOUR.md describes it (fb-matching the command
matcher, fb-numbers the number parsers), for the reference model (fuzz/model/reference_model.py): a
cursor over one stored line."""
from __future__ import annotations

import re
import struct
from functools import lru_cache
from typing import Dict, Optional, Tuple

__all__ = ["Cursor", "LineFailed", "prefix_table", "float_value", "clamp", "f32", "q16", "ACC_LIMIT"]

ACC_LIMIT = 100000000     # the float parser's digit accumulator stops growing here (fb-numbers)


def f32(x: float) -> float:
    """Round to IEEE single precision (the firmware computes in float)."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return float("inf") if x > 0 else float("-inf")


def q16(x: float) -> int:
    """plimit/bias/pwmparams storage: clamp to [0,1], then floor(x*65536 + 0.5) (fb-clamping)."""
    x = min(max(x, 0.0), 1.0)
    return int(f32(f32(x * 65536.0) + 0.5) // 1)



class LineFailed(Exception):
    """A command printed Error (the rest of the line is dropped)."""


# Each token and the spaces after it matched with one regex call, not a Python loop per byte
# (H10 profile: the model's per-byte loops were its main cost).
_COMMAND = re.compile(rb"[ ;]*([^ ;]*)(?:[ ;] *)?")   # separators, a token, one separator, spaces
_WORD = re.compile(rb"([^ ;]*)(?:[ ;] *)?")
_UNSIGNED = re.compile(rb"([0-9]*) *")
_HEX = re.compile(rb"([0-9a-fA-F]*) *")
_SIGNED = re.compile(rb"([+-]?)([0-9]*) *")
_FLOAT = re.compile(rb"([+-]?)([0-9]*)(?:\.([0-9]*))? *")
_FORMAT = re.compile(rb"(u1|s1|u2|s2|u4|s4|f4) *")   # exactly two characters; what follows is not checked


@lru_cache(maxsize=64)
def prefix_table(names: Tuple[str, ...]) -> Dict[bytes, str]:
    """The matcher (fb-matching) as a table: every non-empty prefix of a name -> the first name it starts."""
    table: Dict[bytes, str] = {}
    for name in names:
        encoded = name.encode()
        for end in range(1, len(encoded) + 1):
            table.setdefault(encoded[:end], name)
    return table


def float_value(whole: bytes, fraction: bytes) -> float:
    """The float parser's accumulator (fb-numbers) over the digits before and after the point."""
    if len(whole) + len(fraction) <= 9:
        # Nine digits always fit (the accumulator stops only once it reaches 10^8).
        return f32(f32(float(int(whole + fraction))) / 10.0 ** len(fraction))
    acc = k = f = 0
    for c in whole:
        if acc < ACC_LIMIT:
            acc = acc * 10 + c - 0x30
        else:
            k += 1             # further integer digits scale by 10
    for c in fraction:
        if acc < ACC_LIMIT:
            acc = acc * 10 + c - 0x30
            f += 1             # further fraction digits are ignored
    return f32(f32(float(acc) * 10.0 ** k) / 10.0 ** f)


class Cursor:
    __slots__ = ("s", "pos")

    def __init__(self, s: bytes, pos: int = 0):
        self.s = s
        self.pos = pos

    def command(self, prefixes: Dict[bytes, str]) -> Tuple[bytes, Optional[str]]:
        """Past the separators, (the token, the command it names or None); the token is empty
        at the end of the line. A command is consumed like :meth:`word` consumes a name."""
        m = _COMMAND.match(self.s, self.pos)
        assert m is not None          # the pattern matches the empty string
        tok = m.group(1)
        name = prefixes.get(tok) if tok else None
        if name is not None:
            self.pos = m.end()
        return tok, name

    # Number parsers (fb-numbers). Each returns None and leaves the position alone when no number
    # starts here, and skips the spaces (not ';') after a number it read.
    def unsigned(self) -> Optional[int]:
        m = _UNSIGNED.match(self.s, self.pos)
        assert m is not None          # the pattern matches the empty string
        digits = m.group(1)
        if not digits:
            return None
        self.pos = m.end()
        return int(digits) % 2**32

    def signed(self) -> Optional[int]:
        m = _SIGNED.match(self.s, self.pos)
        assert m is not None          # the pattern matches the empty string
        sign, digits = m.groups()
        if not digits:
            return None
        v = int(digits) % 2**32
        if sign == b"-":
            v = (-v) % 2**32
        self.pos = m.end()
        return v - 2**32 if v >= 2**31 else v

    def float(self) -> Optional[float]:
        m = _FLOAT.match(self.s, self.pos)
        assert m is not None          # the pattern matches the empty string
        sign, whole, fraction = m.groups()
        if not whole and not fraction:
            return None
        value = float_value(whole, fraction or b"")
        self.pos = m.end()
        return -value if sign == b"-" else value

    def hex32(self) -> Optional[int]:
        m = _HEX.match(self.s, self.pos)
        assert m is not None          # the pattern matches the empty string
        digits = m.group(1)
        if not digits:
            return None
        self.pos = m.end()
        return int(digits, 16) % 2**32

    def format(self) -> Optional[bytes]:
        m = _FORMAT.match(self.s, self.pos)
        if m is None:
            return None
        self.pos = m.end()
        return m.group(1)

    def word(self, prefixes: Dict[bytes, str]) -> Optional[str]:
        """The matcher (fb-matching): first name the token is a non-empty prefix of (``prefixes`` from
        :func:`_prefixes`)."""
        m = _WORD.match(self.s, self.pos)
        assert m is not None          # the pattern matches the empty string
        tok = m.group(1)
        name = prefixes.get(tok) if tok else None
        if name is not None:
            self.pos = m.end()
        return name

    # the same, raising LineFailed
    def need(self, value):  # type: ignore[no-untyped-def]
        if value is None:
            raise LineFailed()
        return value


def clamp(v, lo, hi):  # type: ignore[no-untyped-def]
    return lo if v < lo else hi if v > hi else v
