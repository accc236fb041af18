"""IEEE single-precision helpers: the firmware computes in float32, Python in float64.

``f32(x)`` rounds a Python float to the nearest float32 (round-to-nearest-even), which is what
one float32 operation on the HAT yields when applied to the exact result of that operation.
"""
from __future__ import annotations

import struct

_PACK = struct.Struct("<f")


def f32(x: float) -> float:
    """Round to float32; out-of-range values become +-inf like the FPU, NaN stays NaN."""
    try:
        return _PACK.unpack(_PACK.pack(x))[0]
    except OverflowError:
        return float("inf") if x > 0 else float("-inf")


def f32_add(a: float, b: float) -> float:
    """``a + b`` in float32 where either may be NaN: the left operand's NaN (its sign
    included) comes through, as the firmware in the loop computes it (cv=-NaN from
    ``(Inf + NaN) + -NaN``; docs/EMULATOR-MODELS.md "PID"). Python's own addition gives the
    right operand's here, so it is not left to it."""
    if a != a:
        return a
    if b != b:
        return b
    return f32(a + b)


def f32_bits(x: float) -> int:
    return int.from_bytes(_PACK.pack(f32(x)), "little")


def f32_from_bits(bits: int) -> float:
    return _PACK.unpack((bits & 0xFFFFFFFF).to_bytes(4, "little"))[0]
