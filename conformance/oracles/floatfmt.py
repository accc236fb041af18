"""The firmware's float printer (FIRMWARE-BEHAVIOUR.md#fb-float), step by step in float32."""
from __future__ import annotations

from .float32 import f32, f32_bits

__all__ = ["fw_float", "parse_printed"]


def fw_float(value: float) -> str:
    """What the firmware prints for ``value`` (taken as float32): 6 significant digits."""
    bits = f32_bits(value)
    sign = "-" if bits >> 31 else ""
    exponent_field = (bits >> 23) & 0xFF
    if exponent_field == 0:                      # zero and subnormals
        return sign + "0.00000"
    if exponent_field == 0xFF:
        return sign + ("Inf" if bits & 0x7FFFFF == 0 else "NaN")
    f = abs(f32(value))
    shift = 0                                    # f_now = f_orig * 10**shift
    while f < 1:
        f, shift = f32(f * 1e8), shift + 8
    while f >= 1e8:
        f, shift = f32(f / 1e8), shift - 8
    if f < 1e4:
        f, shift = f32(f * 1e4), shift + 4
    if f < 1e6:
        f, shift = f32(f * 1e2), shift + 2
    while f < 1e7:
        f, shift = f32(f * 10), shift + 1
    e = 7 - shift                                # decimal exponent of the leading digit
    u = int(f32(f + 50.0))
    if u >= 100000000:
        u, e = 10000000, e + 1
    digits = str(u)[:6]
    if e < -2 or e > 5:
        return f"{sign}{digits[0]}.{digits[1:]}E{e}"
    if e < 0:
        return f"{sign}0.{'0' * (-e - 1)}{digits}"
    if e == 5:
        return sign + digits
    return f"{sign}{digits[:e + 1]}.{digits[e + 1:]}"


def parse_printed(text: str) -> float:
    """The value a printed float stands for (to its 6 digits); ``Inf``/``NaN`` included."""
    t = text.strip()
    neg = t.startswith("-")
    body = t[1:] if neg else t
    if body == "Inf":
        v = float("inf")
    elif body == "NaN":
        v = float("nan")
    else:
        v = float(body)
    return -v if neg else v
