"""The suite's float printer (conformance/oracles/floatfmt.py) against the worked examples of
FIRMWARE-FACTS."""
from __future__ import annotations

import pytest

from buildhat_conformance.conformance.oracles.floatfmt import fw_float

# FIRMWARE-FACTS §6.3 step 7 and §6.1/§7.4 examples.
FLOATS = [(0, "0.00000"), (-0.0, "-0.00000"), (1, "1.00000"), (10, "10.0000"), (100, "100.000"),
          (90, "90.0000"), (-180, "-180.000"), (65535, "65535.0"), (3.14159265, "3.14159"), (0.1, "0.100000"),
          (0.001, "1.00000E-3"), (9.999999, "10.0000"), (999999.5, "1.00000E6"), (1234567, "1.23457E6"),
          (0.5, "0.500000"), (0.01, "0.0100000"), (1.23457e8, "1.23457E8"), (2.77778e-3, "2.77778E-3"),
          (1e-10, "1.00000E-10"), (1e30, "1.00000E30"), (123456.4, "123456"), (1.5, "1.50000"),
          (-1e-3, "-1.00000E-3"), (float("inf"), "Inf"), (float("-inf"), "-Inf"), (5, "5.00000")]


@pytest.mark.parametrize("value,text", FLOATS)
def test_float_printer(value: float, text: str) -> None:
    assert fw_float(value) == text
