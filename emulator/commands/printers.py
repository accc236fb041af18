"""The firmware's value printers: floats (FIRMWARE-BEHAVIOUR.md#fb-float) and data integers (#fb-data-ints).

Every float step is one IEEE single-precision operation, so each intermediate result is
rounded with :func:`f32`; that is what makes e.g. 9.999999 print as ``10.0000``.
"""
from __future__ import annotations

import math

from ..f32 import f32, f32_bits

__all__ = ["format_float", "format_int"]


def format_float(x: float) -> str:
    """``x`` (rounded to float32 first) as the firmware's ``sfloat`` prints it."""
    bits = f32_bits(x)
    sign = "-" if bits >> 31 else ""
    exponent = (bits >> 23) & 0xFF
    if exponent == 0:                      # zero or subnormal
        return sign + "0.00000"
    if exponent == 0xFF:
        return sign + ("Inf" if bits & 0x7FFFFF == 0 else "NaN")
    f = abs(f32(x))
    e = 7                                  # decimal exponent of the leading digit of x
    while f < 1.0:
        f = f32(f * 1e8)
        e -= 8
    while f >= 1e8:
        f = f32(f / 1e8)
        e += 8
    if f < 1e4:
        f = f32(f * 1e4)
        e -= 4
    if f < 1e6:
        f = f32(f * 1e2)
        e -= 2
    while f < 1e7:
        f = f32(f * 10.0)
        e -= 1
    u = math.trunc(f32(f + 50.0))          # rounds to 6 significant digits
    if u >= 100000000:
        u = 10000000
        e += 1
    digits = f"{u // 100:06d}"
    if e < -2 or e > 5:
        return f"{sign}{digits[0]}.{digits[1:]}E{e}"
    if e < 0:
        return f"{sign}0.{'0' * (-e - 1)}{digits}"
    if e == 5:
        return sign + digits
    return f"{sign}{digits[:e + 1]}.{digits[e + 1:]}"


def format_int(v: int) -> str:
    """A data-line integer (#fb-data-ints): ``+N``, ``-N``, and a zero as `` 0`` (space, zero)."""
    if v > 0:
        return f"+{v}"
    if v < 0:
        return str(v)
    return " 0"
