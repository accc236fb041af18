"""The firmware's number parsers as a model (FIRMWARE-BEHAVIOUR.md#fb-arguments), for predicting what a
command argument becomes. Each returns ``(value, end)`` or ``(None, start)`` on failure;
``end`` is just after the token *and* the spaces that follow it, as the firmware skips them."""
from __future__ import annotations

from typing import Optional, Tuple

from .float32 import f32

__all__ = ["parse_unsigned", "parse_signed", "parse_float", "parse_hex_byte"]

_DIGITS = "0123456789"


def _skip_spaces(s: str, i: int) -> int:
    while i < len(s) and s[i] == " ":
        i += 1
    return i


def parse_unsigned(s: str, i: int = 0) -> Tuple[Optional[int], int]:
    j, v = i, 0
    while j < len(s) and s[j] in _DIGITS:
        v = (v * 10 + int(s[j])) % 2**32
        j += 1
    if j == i:
        return None, i
    return v, _skip_spaces(s, j)


def parse_signed(s: str, i: int = 0) -> Tuple[Optional[int], int]:
    j, neg = i, False
    if j < len(s) and s[j] in "+-":
        neg, j = s[j] == "-", j + 1
    v, end = parse_unsigned(s, j)
    if v is None:
        return None, i
    v = (-v) % 2**32 if neg else v
    return (v - 2**32 if v >= 2**31 else v), end


def parse_float(s: str, i: int = 0) -> Tuple[Optional[float], int]:
    """Optional sign, digits[.digits] / .digits / digits.; no exponent; at most 9 significant
    digits accumulated; value = f32(f32(digits * 10**k) / 10**f)."""
    j, neg = i, False
    if j < len(s) and s[j] in "+-":
        neg, j = s[j] == "-", j + 1
    acc, k, frac, seen = 0, 0, 0, False
    while j < len(s) and s[j] in _DIGITS:
        seen = True
        if acc < 100000000:
            acc = acc * 10 + int(s[j])
        else:
            k += 1
        j += 1
    if j < len(s) and s[j] == ".":
        j += 1
        while j < len(s) and s[j] in _DIGITS:
            seen = True
            if acc < 100000000:
                acc = acc * 10 + int(s[j])
                frac += 1
            j += 1
    if not seen:
        return None, i
    value = f32(float(acc))
    scale = 1.0
    for _ in range(k):
        scale = f32(scale * 10)
    value = f32(value * scale)
    divisor = 1.0
    for _ in range(frac):
        divisor = f32(divisor * 10)
    value = f32(value / divisor)
    return (-value if neg else value), _skip_spaces(s, j)


def parse_hex_byte(s: str, i: int = 0) -> Tuple[Optional[int], int]:
    j, v = i, 0
    while j < len(s) and s[j] in "0123456789abcdefABCDEF":
        v = (v * 16 + int(s[j], 16)) % 2**32
        j += 1
    if j == i:
        return None, i
    return v & 0xFF, _skip_spaces(s, j)
