"""The firmware float printer (FIRMWARE-FACTS §6.3) and data-integer printer (§6.1).

Every expected string is quoted from the facts (§6.3 steps 5-7, §6.1 examples, §7.4 example lines).
"""
from __future__ import annotations

import struct

import pytest

from buildhat_conformance.emulator.commands.printers import format_float, format_int

# §6.3 step 7 (value -> text)
STEP7 = [(0, "0.00000"), (1, "1.00000"), (10, "10.0000"), (100, "100.000"), (90, "90.0000"),
         (-180, "-180.000"), (65535, "65535.0"), (3.14159265, "3.14159"), (0.1, "0.100000"),
         (0.001, "1.00000E-3"), (9.999999, "10.0000"), (999999.5, "1.00000E6"),
         (1234567, "1.23457E6")]
# §6.3 steps 5 and 6
STEPS56 = [(1e6, "1.00000E6"), (1.23457e8, "1.23457E8"), (2.77778e-3, "2.77778E-3"),
           (1e-10, "1.00000E-10"), (1e30, "1.00000E30"), (0.5, "0.500000"), (0.01, "0.0100000"),
           (123456.4, "123456")]
# §6.1: `P3M6: 1.50000 -1.00000E-3 1.23457E8`, `u1` 5 -> `5.00000`, `s2` -180 -> `-180.000`
SECTION61 = [(1.5, "1.50000"), (-1e-3, "-1.00000E-3"), (123456789.0, "1.23457E8"), (5, "5.00000")]
# §7.4 example PID lines (the numbers as printed there)
SECTION74 = [(15.005, "15.0050"), (-0.01, "-0.0100000"), (-100.0, "-100.000"), (0.9, "0.900000"),
             (3.5095, "3.50950"), (-0.019, "-0.0190000"), (0.25, "0.250000"), (15.0, "15.0000"),
             (2.26325, "2.26325"), (-0.0265, "-0.0265000"), (25.0, "25.0000"),
             (0.0157499, "0.0157499"), (0.995, "0.995000"), (-0.0315, "-0.0315000"),
             (50.0, "50.0000"), (-4.98425, "-4.98425"), (-0.9, "-0.900000"), (-0.75, "-0.750000")]


@pytest.mark.parametrize("value,text", STEP7 + STEPS56 + SECTION61 + SECTION74)
def test_float_printer_examples(value, text):
    assert format_float(value) == text


def test_negative_zero_inf_nan():
    # step 2: −0.0 -> `-0.00000`; exponent all ones -> Inf / NaN with `-` if the sign is set
    assert format_float(-0.0) == "-0.00000"
    assert format_float(float("inf")) == "Inf"
    assert format_float(float("-inf")) == "-Inf"
    assert format_float(float("nan")) == "NaN"
    neg_nan = struct.unpack("<f", struct.pack("<I", 0xFFC00000))[0]
    assert format_float(neg_nan) == "-NaN"
    # subnormals print as zero
    assert format_float(struct.unpack("<f", struct.pack("<I", 1))[0]) == "0.00000"


def test_always_six_significant_digits():
    for v in (0.123456, 0.0123456, 1.5, 12.5, 1234.5, 98765.4):
        digits = format_float(v).replace("-", "").replace(".", "").lstrip("0")
        assert len(digits) == 6, (v, format_float(v))


def test_integer_printer():
    # §6.1: `+N` positive, `-N` negative, a space then `0` for zero; int32 min prints in full
    assert format_int(5) == "+5"
    assert format_int(10000) == "+10000"
    assert format_int(-5) == "-5"
    assert format_int(0) == " 0"
    assert format_int(-2147483648) == "-2147483648"
    # `P3M4: +1 -1` and `P0M0:  0` (two spaces after the colon)
    assert "P3M4:" + "".join(" " + format_int(v) for v in (1, -1)) == "P3M4: +1 -1"
    assert "P0M0:" + " " + format_int(0) == "P0M0:  0"
