"""PID controller and process-variable unwrap, recomputed in float32 (FIRMWARE-BEHAVIOUR.md#fb-pid).

The document fixes only the shape (Kp, Ki, Kd with a one-second time unit, integral clamped
to the windup); docs/FIRMWARE-BEHAVIOUR.md#fb-pid-law gives the exact law: e = PV - SP, deadzone,
de = (e - e_prev)/0.01, ie = clamp(ie + e*0.01), output = -(e*Kp + ie*Ki + de*Kd). ``debug 16``
prints every step (#fb-debug-pid).
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Optional

from .float32 import f32
from .floatfmt import fw_float, parse_printed

__all__ = ["PID_LINE", "PidLine", "parse_pid_line", "PidModel", "Unwrapper", "close_to_printed"]

_F = r"(-?(?:[0-9.]+(?:E-?[0-9]+)?|Inf|NaN))"
PID_LINE = re.compile(rf"P([0-3]): pv={_F} sp={_F}: e={_F} ie={_F} de={_F} cv={_F}")
NO_SAMPLE = 1e38          # R6+: "last" at or above this means "no sample yet"


@dataclass(frozen=True)
class PidLine:
    port: int
    pv: str
    sp: str
    e: str
    ie: str
    de: str
    cv: str

    def value(self, name: str) -> float:
        return parse_printed(getattr(self, name))


def parse_pid_line(text: str) -> Optional[PidLine]:
    m = PID_LINE.fullmatch(text)
    if not m:
        return None
    return PidLine(int(m.group(1)), *m.groups()[1:])


def close_to_printed(printed: str, value: float) -> bool:
    """True if ``printed`` is what the firmware prints for ``value``, allowing one unit in the
    sixth significant digit (the order of float operations inside the firmware is not all
    documented, so the last printed digit may legitimately differ)."""
    if printed == fw_float(value):
        return True
    try:
        got = parse_printed(printed)
    except ValueError:
        return False
    if value != value or got != got:
        return False
    ref = parse_printed(fw_float(value))
    unit = abs(ref) * 1.5e-5 if ref else 1e-30
    return abs(got - ref) <= unit


class PidModel:
    """One port's PID state. ``deadzone`` None means R1-R5's fixed band (-0.01, 0.01)."""

    def __init__(self, kp: float, ki: float, kd: float, windup: float, deadzone: Optional[float],
                 ie: float = 0.0, e_prev: float = 0.0):
        self.kp, self.ki, self.kd, self.windup = (f32(x) for x in (kp, ki, kd, windup))
        self.deadzone = None if deadzone is None else f32(deadzone)
        self.ie, self.e_prev = f32(ie), f32(e_prev)

    def step(self, pv: float, sp: float) -> tuple[float, float, float, float]:
        """(e, ie, de, cv) for one 10 ms tick; cv is before the +-1 output clamp."""
        e = f32(pv - sp)
        if self.deadzone is None:
            if -0.01 < e < 0.01:
                e = 0.0
        elif abs(e) < self.deadzone:
            e = 0.0
        de = f32((e - self.e_prev) / 0.01)
        self.e_prev = e
        ie = f32(self.ie + e * 0.01)
        ie = min(max(ie, -self.windup), self.windup)
        self.ie = ie
        cv = f32(f32(f32(e * self.kp) + f32(ie * self.ki)) + f32(de * self.kd))
        return e, ie, de, -cv


class Unwrapper:
    """The process-variable path: raw * scale, then optional unwrap or differentiation.

    ``first_sample`` True is R6+ (start from the first reading after each ``pid``); False is
    R1-R5 (state starts at 0 on a port reset and survives ``pid``).
    """

    def __init__(self, scale: float, unwrap: float, first_sample: bool, differentiate: bool = False):
        self.scale, self.unwrap = f32(scale), f32(unwrap)
        self.first_sample, self.differentiate = first_sample, differentiate
        self.last = NO_SAMPLE if first_sample else 0.0
        self.out = 0.0

    def _fold(self, d: float) -> float:
        half = f32(self.unwrap / 2)
        if d > half:
            d = f32(d - self.unwrap)
        if d < -half:
            d = f32(d + self.unwrap)
        return d

    def sample(self, raw: float) -> float:
        v = f32(raw * self.scale)
        if not self.first_sample:
            if self.unwrap != 0:
                d = self._fold(f32(v - self.last))
                self.last = v
                self.out = f32(self.out + d)
            else:
                self.out = v
            return self.out
        if self.last >= NO_SAMPLE:
            self.last, self.out = v, v
        d = f32(v - self.last)
        if self.unwrap != 0:
            d = self._fold(d)
            self.out = f32(d * 100) if self.differentiate else f32(self.out + d)
        else:
            self.out = f32(d * 100) if self.differentiate else v
        self.last = v
        return self.out
