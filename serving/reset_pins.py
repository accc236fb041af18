"""The HAT's RESET and BOOT0 lines as a host drives them from its GPIO header (control request ``@gpio``).

A Raspberry Pi resets the Build HAT through two GPIOs (FIRMWARE-BEHAVIOUR.md#fb-host-update,
python-build-hat's sequence): RESET on GPIO 4 (active low) and BOOT0 on GPIO 22. While RESET is held low the
chip is stopped: it prints nothing and what the host sends is lost. When RESET is released the chip starts
from flash, which holds the bootloader; the firmware lives in RAM and is gone, so the host finds ``BHBL>``
and must upload again.

BOOT0: python-build-hat holds it low during the pulse. What the chip does with BOOT0 high at release is not
in the facts; the emulator treats it like low (the bootloader starts) and says so in a transcript note.

Request: ``@gpio PIN LEVEL`` with PIN ``reset``/``4`` or ``boot0``/``22`` and LEVEL ``0``, ``1`` or ``z``
(released: the pin is an input again; RESET is pulled up on the HAT, BOOT0 down).
"""
from __future__ import annotations

from typing import Any, Dict, Optional

__all__ = ["ResetPins", "HeldInReset", "PIN_NAMES", "RESET_GPIO", "BOOT0_GPIO"]

RESET_GPIO, BOOT0_GPIO = 4, 22
PIN_NAMES: Dict[str, str] = {"reset": "reset", "4": "reset", "boot0": "boot0", "22": "boot0"}
_LEVELS: Dict[str, Optional[int]] = {"0": 0, "1": 1, "z": None}
# What a released pin reads: RESET has its pull-up (the chip runs), BOOT0 its pull-down.
_RELEASED = {"reset": 1, "boot0": 0}


class HeldInReset:
    """The machine while RESET is low: time passes, nothing is printed, input is lost."""

    def __init__(self, uart: Any, now: int):
        self.uart = uart
        self.now = now
        uart.resize(uart.rx_size, uart.tx_size)     # the rings' contents are gone with the chip's RAM

    def poll(self) -> None:
        self.uart.rx.clear()

    def tick(self) -> None:
        self.now += 1
        self.uart.tick()
        self.uart.rx.clear()


class ResetPins:
    """Levels of RESET and BOOT0; releasing RESET starts the bootloader of ``emulator`` (an ``Emulator``)."""

    def __init__(self, emulator: Any):
        self.emulator = emulator
        self.driven: Dict[str, Optional[int]] = {"reset": None, "boot0": None}

    def level(self, pin: str) -> int:
        driven = self.driven[pin]
        return _RELEASED[pin] if driven is None else driven

    def request(self, words: list) -> str:
        """``@gpio PIN LEVEL`` (words without the verb) -> ``ok``; ValueError on a bad request."""
        if len(words) != 2 or words[0].lower() not in PIN_NAMES or words[1].lower() not in _LEVELS:
            raise ValueError("@gpio takes PIN LEVEL: PIN reset|4|boot0|22, LEVEL 0|1|z")
        pin, driven = PIN_NAMES[words[0].lower()], _LEVELS[words[1].lower()]
        was_low = self.level("reset") == 0
        self.driven[pin] = driven
        now_low = self.level("reset") == 0
        if now_low and not was_low:
            self.emulator.hold_reset()
            self.emulator.note("RESET (GPIO 4) pulled low: the HAT is held in reset")
        elif was_low and not now_low:
            boot0 = self.level("boot0")
            remark = "" if boot0 == 0 else " (BOOT0 high: not in the facts, taken as low)"
            self.emulator.note(f"RESET (GPIO 4) released with BOOT0 {boot0}: the bootloader starts{remark}")
            self.emulator.reset(bootloader=True)
        return "ok"
