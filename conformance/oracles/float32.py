"""IEEE single precision in pure Python.

One binary operation on two float32 values done in double precision and rounded once to
float32 gives the correctly rounded float32 result for +, -, * and / (53 >= 2*24 + 2), so
``f32(a * b)`` is exactly what the RP2040's single-precision code computes.
"""
from __future__ import annotations

import struct

__all__ = ["f32", "f32_bits", "from_bits"]


def f32(x: float) -> float:
    """Round a Python float to the nearest float32 (ties to even), overflow to +-inf."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return float("inf") if x > 0 else float("-inf")


def f32_bits(x: float) -> int:
    return struct.unpack("<I", struct.pack("<f", f32(x)))[0]


def from_bits(bits: int) -> float:
    return struct.unpack("<f", struct.pack("<I", bits & 0xFFFFFFFF))[0]
