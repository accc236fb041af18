"""Motor shaft physics for the emulated motors (model and constants: docs/EMULATOR-MODELS.md).

A :class:`MotorPhysics` belongs to one plugged-in motor. The motor device model (``emulator/
devices/``) creates it from the device's catalogue entry, steps it every millisecond with the
duty the HAT's driver currently applies to that port (``PortController.motor_output()``), and
reads ``speed_pct`` / ``pos_deg`` / ``apos_deg`` to fill its SPEED / POS / APOS data.

Model (first-order DC motor with Coulomb friction, integrated in 1 ms steps):
- a driven motor (duty d in -255..255, 0 included = braking) accelerates towards
  ``rated * d/255`` with time constant ``TAU_S``, minus a constant friction deceleration that
  opposes motion; at rest it stays put while the drive cannot overcome static friction,
  which gives the dead band of ``DEADBAND`` of full drive;
- a coasting motor (``"coast"``) only feels friction and a weak viscous drag;
- ``hold`` (world action ``@hold P 1``) stalls the shaft; ``set_position`` (``@pos P DEG``)
  turns it by hand.
Sign convention (each motor's ``motion_model`` ``direction_rule`` in protocol/devices.json): positive
duty -> SPEED > 0, POS and APOS increasing.
"""
from __future__ import annotations

import math
import random
from typing import Optional, Union

__all__ = ["MotorPhysics", "TAU_S", "DEADBAND", "COAST_TAU_S", "DEFAULT_RATED_DEG_S", "wrap180"]

TAU_S = 0.05             # mechanical time constant when driven (or braked at duty 0)
DEADBAND = 0.08          # fraction of full drive that static friction absorbs
COAST_TAU_S = 0.5        # viscous drag while coasting (driver outputs floating)
DEFAULT_RATED_DEG_S = 1000.0

Drive = Union[int, str, None]


def wrap180(deg: int) -> int:
    """An angle in degrees as -180..179 (the motor's absolute position, APOS)."""
    return (deg + 180) % 360 - 180


class MotorPhysics:
    """Angular speed and shaft angle of one motor.

    ``device_info`` is the catalogue entry (``protocol.devices.active_device(type_id)``); its
    ``motion_model.rated_speed_deg_per_s`` is 100 % SPEED. ``rng`` chooses the absolute shaft
    angle at power-up (captures show small values such as -1 and -9; any angle is possible).
    """

    def __init__(self, device_info: dict, rng: Optional[random.Random] = None) -> None:
        model = device_info.get("motion_model") or {}
        self.rated = float(model.get("rated_speed_deg_per_s", DEFAULT_RATED_DEG_S))
        if self.rated <= 0:
            raise ValueError(f"rated speed must be positive, got {self.rated}")
        self.friction = DEADBAND * self.rated / TAU_S     # deg/s^2 opposing motion
        rng = rng or random.Random(0)
        self.omega = 0.0                   # deg/s
        self.shaft = float(rng.randint(-180, 179))   # absolute angle, not wrapped
        self.pos_zero = self.shaft         # POS counts from the shaft angle at connect
        self.hold = False

    # -- world actions -------------------------------------------------------------------
    def set_position(self, deg: float) -> None:
        """``@pos P DEG``: turn the shaft by hand so that POS reads ``deg`` (APOS moves with it)."""
        self.shaft = self.pos_zero + float(deg)
        self.omega = 0.0

    def reconnect(self) -> None:
        """A new connection: POS restarts at 0, the shaft (APOS) stays where it is."""
        self.pos_zero = self.shaft

    # -- readings ------------------------------------------------------------------------
    @property
    def speed_deg_s(self) -> float:
        return self.omega

    @property
    def speed_pct(self) -> int:
        """SPEED mode value: round(100 * speed / rated), clamped to -100..100."""
        pct = int(math.floor(100.0 * self.omega / self.rated + 0.5))
        return max(-100, min(100, pct))

    @property
    def pos_deg(self) -> int:
        """POS mode value: whole degrees turned since connect (never wraps)."""
        return int(math.floor(self.shaft - self.pos_zero + 0.5))

    @property
    def apos_deg(self) -> int:
        """APOS mode value: the absolute shaft angle, -180..179."""
        return wrap180(int(math.floor(self.shaft + 0.5)))

    # -- time ----------------------------------------------------------------------------
    def step(self, dt_ms: int, duty: Drive) -> None:
        """Advance ``dt_ms`` milliseconds with ``duty`` (+-255, ``"coast"``; None = coast)."""
        if dt_ms < 0:
            raise ValueError(f"dt_ms must be >= 0, got {dt_ms}")
        for _ in range(int(dt_ms)):
            self._step_1ms(duty)

    def at_rest(self, duty: Drive) -> bool:
        """True if a step with ``duty`` changes nothing: the shaft stands and is held, or the
        drive cannot overcome static friction (then it stays so until the duty changes)."""
        return self.omega == 0.0 and (self.hold or abs(self._drive_acc(duty, self.omega)) <= self.friction)

    def _drive_acc(self, duty: Drive, w: float) -> float:
        if duty is None or duty == "coast":
            return -w / COAST_TAU_S
        d = max(-255, min(255, int(duty)))
        return (self.rated * d / 255.0 - w) / TAU_S

    def _step_1ms(self, duty: Drive) -> None:
        dt = 0.001
        if self.hold:
            self.omega = 0.0
            return
        w = self.omega
        drive_acc = self._drive_acc(duty, w)
        if w == 0.0:
            # Static friction: the shaft starts only when the drive overcomes it.
            if abs(drive_acc) <= self.friction:
                return
            acc = drive_acc - math.copysign(self.friction, drive_acc)
            w_new = w + acc * dt
        else:
            acc = drive_acc - math.copysign(self.friction, w)
            w_new = w + acc * dt
            if (w_new > 0) != (w > 0) and abs(drive_acc) <= self.friction:
                w_new = 0.0        # friction stops the shaft; it does not reverse it
        self.shaft += 0.5 * (w + w_new) * dt
        self.omega = w_new
