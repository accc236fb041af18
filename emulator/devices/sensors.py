"""Sensors (22, 23, 25, 3D, 3E, 3F): plausible resting values per mode, and the port-power rule.

Resting values describe a sensor on a desk with nothing in front of it (each mode's ``typical_values``
in protocol/devices.json): colour -1, distance -1 (no echo), proximity 10 (far), force 0 with FRAW about 380.
Scenarios set other values with ``@data P M HH..``.

Power rule (protocol/devices.json's ``power`` notes: the SPIKE colour and distance sensors need port
power, ``set -1``):
a device whose catalogue entry says ``needs_port_power_at_connect`` measures only while the
HAT drives its port negative (any duty < 0, which is what ``set -1`` gives whatever the plimit).
Without it, every input mode reads as "nothing": the no-detection value (-1) for colour and
distance modes, 0 for the rest. Output values written with write1 and ``@data`` values are
reported either way (they do not depend on the sensor's light or sound).
"""
from __future__ import annotations

import random
from typing import Dict, List, Optional

from .active import ActiveDevice

__all__ = ["SensorDevice", "RESTING_VALUES"]

# type -> mode name -> values while powered and idle. Modes not listed read zeros.
RESTING_VALUES: Dict[int, Dict[str, List[float]]] = {
    0x22: {"LPF2-ANGLE": [0, 0], "LPF2-TILT": [0]},
    0x23: {"LPF2-DETECT": [10], "LPF2-CAL": [12, 12, 12]},
    0x25: {"COLOR": [-1], "PROX": [10], "REFLT": [2], "AMBI": [12], "RGB I": [6, 8, 5]},
    0x3D: {"COLOR": [-1], "REFLT": [1], "AMBI": [9], "RREFL": [10, 12],
           "RGB I": [8, 10, 9, 12], "HSV": [200, 180, 12], "SHSV": [200, 180, 12, 9]},
    0x3E: {"DISTL": [-1], "DISTS": [-1], "SINGL": [-1], "LISTN": [0], "TRAW": [0]},
    0x3F: {"FORCE": [0], "TOUCH": [0], "TAP": [0], "FPEAK": [0], "FRAW": [380], "FPRAW": [380]},
}

# Modes whose "nothing measured" value is -1 rather than 0.
_NO_DETECTION = {"COLOR", "DISTL", "DISTS", "SINGL"}


class SensorDevice(ActiveDevice):
    def __init__(self, entry: dict, rng: Optional[random.Random] = None):
        super().__init__(entry, rng)
        self.needs_power = bool((entry.get("power") or {}).get("needs_port_power_at_connect"))

    @property
    def powered(self) -> bool:
        if not self.needs_power:
            return True
        duty = self.port_duty()
        return isinstance(duty, int) and duty < 0

    def model_values(self, mode: int, now: int) -> List[float]:
        info = self.modes[mode]
        count = info["format"]["count"]
        name = info["name"]
        if not self.powered:
            return [-1 if name in _NO_DETECTION else 0] * count
        values = list(RESTING_VALUES.get(self.type_id, {}).get(name, []))
        return (values + [0] * count)[:count]
