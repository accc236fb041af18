"""The per-port set-point generator (FIRMWARE-BEHAVIOUR.md#fb-setpoint): constants and waveforms.

One :class:`SetpointGenerator` per port, stepped once per 10 ms controller tick by
``emulator/motor/controller.py``. Every float operation the firmware does in single precision is
rounded with :func:`f32`; the phase accumulator is advanced in double and then rounded to
float, which is why a 1 s pulse ends after 101 ticks rather than 100.
"""
from __future__ import annotations

import math
from typing import Callable, Optional, Tuple

from ..f32 import f32

__all__ = ["SetpointGenerator", "SINE_TABLE", "WAVE_SHAPES", "TICK_S", "MIN_PERIOD", "MAX_PERIOD"]

TICK_S = 0.01            # PWM_UPDATE: 10 ms, added in double precision
MIN_PERIOD = 0.02        # cmd_set_wave clamps the period to [0.02, 1e30] s
MAX_PERIOD = 1e30
WAVE_SHAPES = ("square", "sine", "triangle", "pulse", "ramp")

# sin(2*pi*k/256) rounded to 5 decimals, stored as float32 (the firmware's 256-entry table).
SINE_TABLE: Tuple[float, ...] = tuple(f32(round(math.sin(2 * math.pi * k / 256), 5)) for k in range(256))


def _clamp(x: float, lo: float, hi: float) -> float:
    # Written as two comparisons, like the firmware: a NaN passes through unchanged.
    if x < lo:
        x = lo
    if x > hi:
        x = hi
    return x


def _same_sign(a: float, b: float) -> bool:
    # Equal floats differ only as 0.0 and -0.0 (which the debug line prints differently).
    return a != 0.0 or math.copysign(1.0, a) == math.copysign(1.0, b)


class SetpointGenerator:
    """Shape, parameters and phase accumulator of one port's set point.

    ``shape`` is one of :data:`WAVE_SHAPES` or ``"var"`` (R6+). A constant is a square wave
    with ``a == b`` and period 1 (that is how ``set <x>`` stores it). For ``var`` the
    parameters are ``vmin, vmax, slope, offset`` and the value comes from a sensor variable
    read through the callable given to :meth:`step`.
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """The port reset (#fb-port-reset): constant 0, period 1, accumulator 0."""
        self.shape = "square"
        self.a = 0.0
        self.b = 0.0
        self.period = 1.0
        self.phase = 0.0
        self.acc = 0.0
        self.vmin = self.vmax = self.slope = self.offset = 0.0

    # -- what commands store ---------------------------------------------------------------
    def set_constant(self, x: float) -> None:
        """``set <x>`` (also ``on``/``off``): square with a = b = x, T = 1, phi = 0.

        The accumulator is deliberately *not* reset (the firmware does not).
        """
        self.shape = "square"
        self.a = self.b = f32(x)
        self.period = 1.0
        self.phase = 0.0

    def set_wave(self, shape: str, a: float, b: float, period: float, phase: float) -> None:
        """``set <shape> a b period phase``: clamps period and phase, resets the accumulator."""
        if shape not in WAVE_SHAPES:
            raise ValueError(f"unknown waveform {shape!r}; expected one of {', '.join(WAVE_SHAPES)}")
        self.shape = shape
        self.a, self.b = f32(a), f32(b)
        self.period = f32(_clamp(f32(period), MIN_PERIOD, MAX_PERIOD))
        self.phase = f32(_clamp(f32(phase), 0.0, 1.0))
        self.acc = 0.0

    def set_var_map(self, vmin: float, vmax: float, slope: float, offset: float) -> None:
        """``set var min max slope offset`` (R6+): stored unclamped, before the svar is parsed."""
        self.shape = "var"
        self.vmin, self.vmax = f32(vmin), f32(vmax)
        self.slope, self.offset = f32(slope), f32(offset)

    @property
    def is_constant(self) -> bool:
        return self.shape == "square" and self.a == self.b

    # -- the 10 ms update ----------------------------------------------------------------
    def step(self, read_var: Optional[Callable[[], float]] = None) -> tuple[float, Optional[str]]:
        """Advance one 10 ms tick; returns (set point, ``"pulse done"``/``"ramp done"`` or None).

        ``read_var`` returns the sensor variable for the ``var`` shape (its last value when no
        data exists); it is only called for that shape.
        """
        done = None
        u = f32(self.acc + TICK_S)           # double add, then rounded to float
        if u >= self.period:
            u = f32(u - self.period)
            if self.shape in ("pulse", "ramp"):
                done = f"{self.shape} done"
                # The end: a constant at the second parameter. It must stop being a pulse/ramp,
                # otherwise it would report "done" again a second later.
                self.shape = "square"
                self.a = self.b
                self.period = 1.0
                self.phase = 0.0
            if u >= self.period:
                u = 0.0
        self.acc = u
        a = self.a
        if self.shape == "square" and a == self.b and _same_sign(a, self.b):
            return a, done          # a constant (the usual case): its phase does not matter
        x = f32(f32(u / self.period) + self.phase)
        if x >= 1.0:
            x = f32(x - 1.0)
        return self._value(x, read_var), done

    def _value(self, x: float, read_var: Optional[Callable[[], float]]) -> float:
        a, b = self.a, self.b
        shape = self.shape
        if shape == "square":
            return b if x >= 0.5 else a
        if shape == "sine":
            i = math.trunc(f32(f32(x * 256.0) + 0.5)) % 256
            return f32(a + f32(f32(f32(b - a) * f32(SINE_TABLE[i] + 1.0)) * 0.5))
        if shape == "triangle":
            if x >= 0.5:
                x = f32(1.0 - x)
            return f32(a + f32(f32(b - a) * f32(2.0 * x)))
        if shape == "pulse":
            return a
        if shape == "ramp":
            return f32(a + f32(f32(b - a) * x))
        if shape == "var":
            v = read_var() if read_var is not None else 0.0
            return _clamp(f32(f32(v - self.offset) * self.slope), self.vmin, self.vmax)
        raise AssertionError(f"unknown set-point shape {shape!r}")
