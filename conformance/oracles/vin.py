"""``vin`` output (FIRMWARE-BEHAVIOUR.md#fb-vin): integer millivolts, a third decimal of 5 rounds down."""
from __future__ import annotations

__all__ = ["adc_to_mv", "vin_text"]


def adc_to_mv(adc: int) -> int:
    return ((adc * 57) // 10) * 3300 // 4096


def vin_text(mv: int) -> str:
    k = (mv + 4) // 10
    return f"{k // 100}.{k % 100:02d} V"
