"""The PWM drive path of one port (FIRMWARE-BEHAVIOUR.md#fb-pwm-path): value -> Q16 -> bias/slow PWM ->
limit -> duty.

``DrivePath.drive(x)`` returns the signed duty (+-255) the motor driver gets; the controller
writes it to the HAT only when it differs from the previous write. Per-release behaviour comes
from the profile features: ``plimit_scope`` (``"global"``: one limit written to every port and
never reset; ``"per_port"``: reset to 0.1 with every port reset) and the presence of ``bias``
(R1-R5) or ``pwmparams`` (R6+) in the command table.
"""
from __future__ import annotations

import math
from typing import Union

__all__ = ["DrivePath", "to_q16", "param_q16", "duty_from_q16", "DEFAULT_LIMIT_Q16", "COAST"]

Q16_ONE = 65536
DEFAULT_LIMIT_Q16 = 6554      # 0.1, the limit at boot (and after every R6+ port reset)
COAST = "coast"
Duty = Union[int, str]


def to_q16(x: float) -> int:
    """Clamp to [-1, 1], then (trunc(x*131072) + 1) / 2 with C division: +1 -> 65536, -1 -> -65535.

    A NaN passes the clamp (both comparisons are false); the RP2040's float-to-int
    conversion turns it into 0.
    """
    if x < -1.0:
        x = -1.0
    if x > 1.0:
        x = 1.0
    if math.isnan(x):
        return 0
    t = math.trunc(x * 131072.0) + 1
    return abs(t) // 2 * (1 if t >= 0 else -1)


def param_q16(x: float) -> int:
    """``plimit``/``port_plimit``/``bias``/``pwmparams``: clamp to [0, 1], floor(x*65536 + 0.5)."""
    if x < 0.0:
        x = 0.0
    if x > 1.0:
        x = 1.0
    if math.isnan(x):
        return 0
    return math.floor(x * 65536.0 + 0.5)


def duty_from_q16(v: int) -> int:
    """(v*255 + 127) >> 16, an arithmetic (flooring) shift: -0.1 -> -26, +0.1 -> 25."""
    return (v * 255 + 127) >> 16


class DrivePath:
    """Bias (R1-R5), PWM threshold / minimum (R6+), limit and the slow-PWM accumulator."""

    def __init__(self, biased: bool) -> None:
        self.biased = biased          # R1-R5 bias mapping; otherwise the R6+ pwmparams path
        self.limit = DEFAULT_LIMIT_Q16
        self.reset()

    def reset(self, reset_limit: bool = False) -> None:
        """The port reset (#fb-port-reset): bias / pwmparams 0; the limit only when ``reset_limit``."""
        self.bias = 0
        self.pwmthresh = 0
        self.minpwm = 0
        self.slow_acc = 0
        if reset_limit:
            self.limit = DEFAULT_LIMIT_Q16

    def drive(self, x: float) -> int:
        """The duty (+-255) for drive value ``x`` (the setpoint in PWM mode, the PID output)."""
        u = to_q16(x)
        if self.biased:
            if u > 0:
                u += self.bias
            elif u < 0:
                u -= self.bias
            v = u
        else:
            v = self._slow_pwm(u)
        if v > self.limit:
            v = self.limit
        if v < -self.limit:
            v = -self.limit
        return duty_from_q16(v)

    def _slow_pwm(self, u: int) -> int:
        if abs(u) < self.minpwm:
            u = 0
        thresh = self.pwmthresh
        if abs(u) >= thresh:
            return u
        # Below the threshold: accumulate and emit +-thresh pulses ("slow PWM").
        self.slow_acc += u
        if self.slow_acc >= thresh:
            v = thresh
        elif self.slow_acc <= -thresh:
            v = -thresh
        else:
            v = 0
        self.slow_acc -= v
        return v
