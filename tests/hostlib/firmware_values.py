"""Values the firmware prints, computed from FIRMWARE-FACTS formulas (never from the emulator)."""
from __future__ import annotations

__all__ = ["vin_volts"]


def vin_volts(adc: int) -> float:
    """FIRMWARE-FACTS §4.4: mV = ((adc*57)/10)*3300/4096 in integers, printed via k = (mV+4)//10."""
    mv = ((adc * 57) // 10) * 3300 // 4096
    k = (mv + 4) // 10
    return float(f"{k // 100}.{k % 100:02d}")
