"""The SPIKE Essential 3x3 colour light matrix (type 0x40): all modes are outputs.

Reported data: each mode echoes the last value written to it, zeros before any write (a guess: the
catalogue, protocol/devices.json, lists every mode as write-only; docs/EMULATOR-MODELS.md "Devices").

Power rule (the ``power`` note of 0x40 in protocol/devices.json: it "must receive motor power within a
short time after setup or it disconnects"; the delay
is not in the facts, so it is chosen here and is profile data, ``matrix_power_grace_ms``): once
the data phase starts, the matrix must see a non-zero motor drive on its port. If the drive is
0 or coast for more than the grace in a row, the matrix stops talking for good; the HAT then times out
(500 ms) and the port stays empty until the matrix is unplugged and plugged in again
(matching "off leaves it dead until it is reconnected").
"""
from __future__ import annotations

import math
import random
from typing import Optional

from .active import ActiveDevice

__all__ = ["MatrixDevice", "POWER_GRACE_MS"]

POWER_GRACE_MS = 1000      # used when the port's profile does not set matrix_power_grace_ms


class MatrixDevice(ActiveDevice):
    def __init__(self, entry: dict, rng: Optional[random.Random] = None):
        super().__init__(entry, rng)
        self._unpowered_since: Optional[int] = None

    @property
    def grace_ms(self) -> int:
        port = self.port
        features = port.hat.profile.features if port is not None else {}
        return int(features.get("matrix_power_grace_ms", POWER_GRACE_MS))

    def restart_grace(self, now: int) -> None:
        """The unpowered time counts from ``now`` (``--booted``: the host gets the whole grace)."""
        if self._unpowered_since is not None:
            self._unpowered_since = now

    def _powered(self) -> bool:
        duty = self.port_duty()
        return isinstance(duty, int) and duty != 0

    def step(self, now: int) -> None:
        if self.dead or self.state != "data":
            self._unpowered_since = None
            return
        if self._powered():
            self._unpowered_since = None
        elif self._unpowered_since is None:
            self._unpowered_since = now
        elif now - self._unpowered_since > self.grace_ms:
            self.dead = True
            if self.port is not None:
                self.port.hat.note(f"P{self.port.index}: LED matrix unpowered for more than "
                                   f"{self.grace_ms} ms: it stops talking (emulator model)")

    def step_due(self, now: int) -> float:
        # step() only clears or starts the unpowered timer, or kills the matrix when it runs out.
        if self.dead or self.state != "data" or self._powered():
            return math.inf if self._unpowered_since is None else now + 1
        if self._unpowered_since is None:
            return now + 1
        return self._unpowered_since + self.grace_ms + 1
