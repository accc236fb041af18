"""LPF2 device models: active devices built from devices.json, passive IDs, and the HAT's
record of what an active device told it (``info.DeviceInfo``)."""
from __future__ import annotations

import random
from typing import Optional, Union

from ...protocol.devices import active_device, parse_device_spec
from .active import ActiveDevice
from .matrix import MatrixDevice
from .motor import MotorDevice
from .passive import PassiveDevice
from .sensors import SensorDevice

__all__ = ["make_device", "ActiveDevice", "MotorDevice", "SensorDevice", "MatrixDevice",
           "PassiveDevice", "Device"]

Device = Union[ActiveDevice, PassiveDevice]


def make_device(spec, rng: Optional[random.Random] = None) -> Optional[Device]:
    """A device from a SPEC (``"0x30"``, ``"passive 8"``, ``"none"``) or a parsed
    ``("active", 0x30)`` / ``("passive", 8)`` / None. Raises ValueError/KeyError on bad specs."""
    parsed = parse_device_spec(spec) if isinstance(spec, str) else spec
    if parsed is None:
        return None
    kind, ident = parsed
    if kind == "passive":
        return PassiveDevice(ident)
    entry = active_device(ident)
    category = entry.get("category", "")
    if category.startswith("motor"):
        return MotorDevice(entry, rng)
    if category == "light":      # the 3x3 light matrix: needs motor power (matrix.py)
        return MatrixDevice(entry, rng)
    return SensorDevice(entry, rng)
