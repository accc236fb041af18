"""Single precision (emulator/f32.py) from first principles: IEEE 754 binary32 bit patterns and
round-to-nearest-even, as the firmware's float operations yield them."""
from __future__ import annotations

import math

import pytest

from buildhat_conformance.emulator.f32 import f32, f32_bits, f32_from_bits


@pytest.mark.parametrize("x,bits", [(1.0, 0x3F800000), (-2.0, 0xC0000000), (0.5, 0x3F000000),
                                    (0.1, 0x3DCCCCCD), (float("inf"), 0x7F800000), (0.0, 0)])
def test_bit_patterns_are_ieee_binary32(x, bits):
    assert f32_bits(x) == bits
    assert f32_from_bits(bits) == f32(x)


def test_rounding_is_to_the_nearest_float32():
    # 1 + 2^-24 lies exactly between 1 and the next float32 (1 + 2^-23): ties go to the even one, 1.
    assert f32(1 + 2 ** -24) == 1.0
    assert f32(1 + 3 * 2 ** -25) == 1 + 2 ** -23          # past the middle: up
    assert f32(0.1) != 0.1 and abs(f32(0.1) - 0.1) < 2 ** -27


def test_out_of_range_becomes_infinity_and_nan_stays_nan():
    assert f32(1e39) == math.inf and f32(-1e39) == -math.inf
    assert math.isnan(f32(math.nan))
