"""Motors (26, 2E, 2F, 30, 31, 41, 4B, 4C): mode values from the shaft physics
(emulator/motor/shaft_physics.py).

SPEED = % of rated speed, POS = whole degrees since connect (never wraps, 0 at every connect),
APOS = absolute angle wrapped to -180..179, CALIB = [0, APOS in 0.1 deg as 0..3599] (its
``typical_values`` in protocol/devices.json: the first value is unknown), STATS/TEST zeros, POWER = the
last value written to it (else 0).
At rest the absolute encoder flickers: APOS reads the true angle plus a jitter of -1, 0 or +1
that changes every 5..25 ms (seeded, so runs are repeatable); that is what makes a resting
motor send every few ms (protocol/devices.json's ``_meta`` ``data_output``).
"""
from __future__ import annotations

import math
import random
from typing import List, Optional

from ..motor.shaft_physics import MotorPhysics, wrap180
from .active import ActiveDevice

__all__ = ["MotorDevice", "JITTER_MIN_MS", "JITTER_MAX_MS"]

JITTER_MIN_MS = 5
JITTER_MAX_MS = 25
_ENCODER_MODES = ("APOS", "CALIB")    # the modes whose values include the jitter


class MotorDevice(ActiveDevice):
    sample_ms = 5            # a motor reports at most every 5 ms while it moves (inferred)

    def __init__(self, entry: dict, rng: Optional[random.Random] = None):
        super().__init__(entry, rng)
        self.physics = MotorPhysics(entry, self.rng)
        self._jitter = 0
        self._jitter_next = 0
        self._last_step: Optional[int] = None
        # The shaft was at rest, under a drive that cannot move it, when the port last worked
        # out when to tick again: the milliseconds it then slept through moved nothing.
        self._resting = False
        self._encoder_modes = {i for i, m in self.modes.items() if m["name"] in _ENCODER_MODES}

    def begin_setup(self, now: int) -> None:
        super().begin_setup(now)
        self.physics.reconnect()

    def step(self, now: int) -> None:
        if self._last_step is None:
            self._last_step = now - 1
        dt = now - self._last_step
        if dt > 1 and self._resting:
            # The port slept through these milliseconds (see step_due): the shaft stood still
            # and only the jitter changed. Its draws are made now, in the same order (the rng
            # is the device's own), before anything reads it.
            dt = 1
            while self._jitter_next < now:
                self._draw_jitter(self._jitter_next)
        if dt > 0:
            self.physics.step(dt, self.port_duty())
            self._last_step = now
        if self.physics.speed_deg_s != 0.0:
            self._jitter = 0
        elif now >= self._jitter_next:
            self._draw_jitter(now)

    def _draw_jitter(self, now: int) -> None:
        jitter = self.rng.choice((-1, 0, 1))
        if jitter != self._jitter:
            self._stale = True
        self._jitter = jitter
        self._jitter_next = now + self.rng.randint(JITTER_MIN_MS, JITTER_MAX_MS)

    def step_due(self, now: int) -> float:
        # Every millisecond while the shaft moves or its drive can move it (a new drive wakes
        # the port). At rest only the jitter changes; its draws wait for the next tick unless
        # the sampled payload shows it (APOS, CALIB) and the samples must see each change.
        physics = self.physics
        self._resting = physics.omega == 0.0 and physics.at_rest(self.port_duty())
        if not self._resting:
            self._stale = True
            return now + 1
        if self.state == "data" and self.rate_ms <= 0 and self._shows_encoder():
            return self._jitter_next
        return math.inf

    def _shows_encoder(self) -> bool:
        """The selected mode (or the modes of its combi) reads the absolute encoder."""
        combi = self.combis.get(self.mode)
        modes = [m for m, _dataset in combi] if combi else [self.mode]
        return any(m in self._encoder_modes for m in modes)

    @property
    def apos(self) -> int:
        return wrap180(self.physics.apos_deg + self._jitter)

    def model_values(self, mode: int, now: int) -> List[float]:
        name = self.modes[mode]["name"]
        count = self.modes[mode]["format"]["count"]
        if name == "SPEED":
            return [self.physics.speed_pct]
        if name == "POS":
            return [self.physics.pos_deg]
        if name == "APOS":
            return [self.apos]
        if name == "CALIB":
            return [0, (self.apos % 360) * 10]
        return [0] * count

    # -- world actions -----------------------------------------------------------------------
    def hold(self, on: bool) -> None:
        """``@hold P 0|1``: stall the shaft / let it go."""
        self.physics.hold = bool(on)

    def set_position(self, deg: float) -> None:
        """``@pos P DEG``: turn the shaft by hand so that POS reads DEG."""
        self.physics.set_position(deg)
