"""Sensor variables and the PID control law (FIRMWARE-BEHAVIOUR.md#fb-pid).

- :class:`SensorVariable` ("svar"/"pv"): where a value is read from (port, mode, byte offset,
  format), its scale and phase unwrap, and the unwrap state. It is used as the PID's process
  variable and as the source of ``set var`` (R6+). The initialisation of the unwrap state is
  per release (``Profile.features["unwrap_init"]``).
- :class:`Pid`: gains, windup, deadzone and the integrator / previous-error state, and the
  10 ms update that returns the debug-16 quantities.

All arithmetic follows the firmware's float semantics via :func:`f32`.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Optional

from ..f32 import f32, f32_add

__all__ = ["SensorVariable", "Pid", "PidStep", "decode_value", "NO_SAMPLE", "FIXED_DEADZONE"]

# R6+: "no sample yet" marker (1.1e38 as float); anything >= 1e38 means "take the next sample as is".
NO_SAMPLE = f32(1.1e38)
_NO_SAMPLE_LIMIT = 1e38
# R1-R5 zero errors inside this fixed band (a double constant in the comparison).
FIXED_DEADZONE = 0.01
DT = 0.01                # the controller period in seconds, a double constant


def decode_value(data: bytes, offset: int, code: int) -> float:
    """Read one little-endian value of format ``code`` (parser.FORMAT_CODES) as a float.

    Bytes beyond the stored payload read as 0 (the firmware reads its zero-initialised
    mode buffer).
    """
    size = code & 0x0F
    raw = bytes(data[offset:offset + size]).ljust(size, b"\x00")
    if code & 0x200:
        return struct.unpack("<f", raw)[0]
    value = int.from_bytes(raw, "little", signed=bool(code & 0x100))
    return f32(float(value))


class SensorVariable:
    """One svar: port, mode, offset, format, scale, unwrap, and its unwrap state.

    ``unwrap_init`` is the profile feature: ``"zero_persistent"`` (R1-R5: ``last`` and the
    unwrapped value start at 0 and survive ``pid``) or ``"first_sample"`` (R6+: every
    ``pid``/``pid_diff``/``set var`` sets the no-sample marker, and the next sample is taken
    as is).
    """

    def __init__(self, unwrap_init: str) -> None:
        if unwrap_init not in ("zero_persistent", "first_sample"):
            raise ValueError(f"unknown unwrap_init {unwrap_init!r}")
        self.unwrap_init = unwrap_init
        self.clear()

    def clear(self) -> None:
        """The port reset (#fb-port-reset): fields cleared and unwrap state back to its start."""
        self.port = 0
        self.mode = 0
        self.offset = 0
        self.format = 0x001
        self.scale = 0.0
        self.unwrap = 0.0
        self.value = 0.0           # the output (PV): unwrapped, or differentiated
        self.last = NO_SAMPLE if self.unwrap_init == "first_sample" else 0.0

    def restart(self) -> None:
        """What ``pid``/``pid_diff``/``set var`` do to the state before parsing (R6+ only)."""
        if self.unwrap_init == "first_sample":
            self.last = NO_SAMPLE

    def sample(self, data: Optional[bytes], differentiate: bool = False) -> Optional[float]:
        """Update from the mode's latest payload; None (state untouched) if it has no data."""
        if data is None:
            return None
        v = f32(decode_value(data, self.offset, self.format) * self.scale)
        if self.unwrap_init == "zero_persistent":
            self._sample_persistent(v)
        else:
            self._sample_first(v, differentiate)
        return self.value

    def _fold(self, d: float) -> float:
        # One fold into +-U/2, as two literal comparisons (a negative U follows them too).
        half = f32(self.unwrap * 0.5)
        if d > half:
            d = f32(d - self.unwrap)
        if d < -half:
            d = f32(d + self.unwrap)
        return d

    def _sample_persistent(self, v: float) -> None:
        if self.unwrap != 0.0:
            d = f32(v - self.last)
            self.last = v
            self.value = f32(self.value + self._fold(d))
        else:
            self.value = v

    def _sample_first(self, v: float, differentiate: bool) -> None:
        if self.last >= _NO_SAMPLE_LIMIT:
            self.last = v
            self.value = v
        d = f32(v - self.last)
        if self.unwrap == 0.0:
            self.value = f32(d * 100.0) if differentiate else v
        else:
            d = self._fold(d)
            self.value = f32(d * 100.0) if differentiate else f32(self.value + d)
        self.last = v


@dataclass
class PidStep:
    """The quantities of one update, as the debug-16 line shows them."""

    pv: float
    sp: float
    e: float      # after the deadzone
    ie: float     # after the windup clamp
    de: float
    cv: float     # before the +-1 clamp of the drive path


class Pid:
    """Gains and state of one port's PID (R1-R5 fixed deadzone, R6+ parameter).

    ``deadzone_rule`` is ``Profile.features["pid_deadzone"]``: ``"fixed"`` or ``"parameter"``.
    """

    def __init__(self, deadzone_rule: str) -> None:
        if deadzone_rule not in ("fixed", "parameter"):
            raise ValueError(f"unknown pid_deadzone {deadzone_rule!r}")
        self.deadzone_rule = deadzone_rule
        self.clear()

    def clear(self) -> None:
        """The port reset: gains and state 0 (``pid`` itself never clears the state)."""
        self.kp = self.ki = self.kd = self.windup = self.deadzone = 0.0
        self.ie = 0.0
        self.e_prev = 0.0

    def _apply_deadzone(self, e: float) -> float:
        if self.deadzone_rule == "fixed":
            return 0.0 if -FIXED_DEADZONE < e < FIXED_DEADZONE else e
        return 0.0 if abs(e) < self.deadzone else e

    def step(self, pv: float, sp: float) -> PidStep:
        e = self._apply_deadzone(f32(pv - sp))
        de = f32(f32(e - self.e_prev) / DT)          # float subtract, double divide
        self.e_prev = e
        ie = f32(self.ie + e * DT)                   # in double, then rounded
        # The windup clamp: two comparisons, so a NaN integrator stays NaN.
        if ie > self.windup:
            ie = self.windup
        if ie < -self.windup:
            ie = -self.windup
        self.ie = ie
        # Of two NaNs the sum keeps the left operand's, and the firmware in the loop adds the
        # integral term to the proportional one (IEEE addition is commutative otherwise).
        t = f32_add(f32(ie * self.ki), f32(e * self.kp))
        t = f32_add(t, f32(de * self.kd))
        return PidStep(pv=pv, sp=sp, e=e, ie=ie, de=de, cv=-t)

