"""The suite's vin oracle (conformance/oracles/vin.py) against the worked examples of FIRMWARE-FACTS."""
from __future__ import annotations

import pytest

from buildhat_conformance.conformance.oracles.vin import adc_to_mv, vin_text


@pytest.mark.parametrize("mv,text", [(7200, "7.20 V"), (7205, "7.20 V"), (7206, "7.21 V"), (9999, "10.00 V"),
                                     (0, "0.00 V"), (18805, "18.80 V")])
def test_vin_rounding(mv: int, text: str) -> None:
    assert vin_text(mv) == text


def test_vin_adc_conversion() -> None:
    assert adc_to_mv(4095) == 18805 and vin_text(adc_to_mv(1742)) == "8.00 V"
