"""Passive devices (IDs 1..11): what the HAT's ID scan reads on the port's ID pins.

The raw signature a scan reads depends on the scan (FIRMWARE-BEHAVIOUR.md#fb-debug-signatures: R1/R2
and R3+ sample differently and use different tables), so the device gives the signature of its ID in the
release's table (:meth:`PassiveDevice.signature_in`); ``signature`` is the catalogue's
(devices.json lists the R3+ codes)."""
from __future__ import annotations

from typing import Mapping

from ...protocol.devices import passive_device, passive_ids

__all__ = ["PassiveDevice", "BUTTON_ID", "BUTTON_RELEASED"]

BUTTON_ID = 5
BUTTON_RELEASED = 0xCCCC   # devices.json: signature 0xCCCC = released, any other = pressed
_BUTTON_PRESSED = 0x4444


class PassiveDevice:
    kind = "passive"

    def __init__(self, passive_id: int):
        if passive_id not in passive_ids():
            raise ValueError(f"passive device id must be one of {passive_ids()}, got {passive_id}")
        self.passive_id = passive_id
        self.entry = passive_device(passive_id)
        self.pressed = False          # only meaningful for the button (ID 5)

    @property
    def signature(self) -> int:
        """The signature word a scan reads (the catalogue's first one; the button's follows its state)."""
        if self.passive_id == BUTTON_ID:
            return _BUTTON_PRESSED if self.pressed else BUTTON_RELEASED
        return int(self.entry["signatures"][0], 16)

    def signature_in(self, ids: Mapping[int, int]) -> int:
        """The signature a scan using the table ``ids`` (signature -> ID) reads: the table's
        first code for this ID; for the button, 0xCCCC released and another code pressed."""
        codes = [sig for sig, pid in ids.items() if pid == self.passive_id]
        if self.passive_id == BUTTON_ID:
            if not self.pressed:
                return BUTTON_RELEASED
            codes = [sig for sig in codes if sig != BUTTON_RELEASED]
        return codes[0] if codes else self.signature

    def press(self, pressed: bool) -> None:
        if self.passive_id != BUTTON_ID:
            raise ValueError(f"passive ID {self.passive_id} is not a button (ID {BUTTON_ID})")
        self.pressed = bool(pressed)
