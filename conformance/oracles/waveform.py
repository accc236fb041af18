"""The set-point generator, tick by tick (FIRMWARE-BEHAVIOUR.md#fb-setpoint; shapes from the
document's `set`).

One ``tick()`` is one 10 ms controller update. The phase accumulator is float32 and the
``+ 0.01`` is done in double then rounded, which is why a 0.1 s pulse ends after 11 ticks.
"""
from __future__ import annotations

import math
from typing import List, Optional, Tuple

from .float32 import f32

__all__ = ["SINE_TABLE", "Generator", "ticks_until_done", "shape_value"]

#: sin(2*pi*k/256) rounded to 5 decimals, as float32 (FIRMWARE-BEHAVIOUR.md#fb-setpoint).
SINE_TABLE = [f32(round(math.sin(2 * math.pi * k / 256), 5)) for k in range(256)]

MIN_PERIOD, MAX_PERIOD = 0.02, 1e30


def shape_value(shape: str, a: float, b: float, x: float) -> float:
    """The set-point at phase position x in [0, 1) for one period of ``shape``."""
    span = f32(b - a)
    if shape == "square":
        return b if x >= 0.5 else a
    if shape == "sine":
        i = int(f32(f32(x * 256) + 0.5)) % 256
        return f32(a + f32(f32(span * f32(SINE_TABLE[i] + 1)) * 0.5))
    if shape == "triangle":
        if x >= 0.5:
            x = f32(1 - x)
        return f32(a + f32(span * f32(2 * x)))
    if shape == "pulse":
        return a
    if shape == "ramp":
        return f32(a + f32(span * x))
    raise ValueError(f"unknown shape {shape!r}")


class Generator:
    """A port's set-point generator after ``set <shape> a b period phase`` (accumulator at 0)."""

    def __init__(self, shape: str, a: float, b: float, period: float, phase: float):
        self.shape, self.a, self.b = shape, f32(a), f32(b)
        self.period = f32(min(max(f32(period), MIN_PERIOD), MAX_PERIOD))
        self.phase = f32(min(max(f32(phase), 0.0), 1.0))
        self.acc = 0.0

    def tick(self) -> Tuple[float, Optional[str]]:
        """(set-point, "pulse done"/"ramp done" or None) for the next 10 ms tick."""
        done = None
        u = f32(self.acc + 0.01)
        if u >= self.period:
            u = f32(u - self.period)
            if self.shape in ("pulse", "ramp"):
                done = f"{self.shape} done"
                self.shape, self.a, self.period, self.phase = "square", self.b, 1.0, 0.0
        if u >= self.period:
            u = 0.0
        self.acc = u
        x = f32(f32(u / self.period) + self.phase)
        if x >= 1:
            x = f32(x - 1)
        return shape_value(self.shape, self.a, self.b, x), done

    def run(self, ticks: int) -> List[Tuple[float, Optional[str]]]:
        return [self.tick() for _ in range(ticks)]


def ticks_until_done(period: float) -> int:
    """On which tick after the command a pulse or ramp of this duration ends."""
    g = Generator("pulse", 1, 0, period, 0)
    for n in range(1, 10**7):
        if g.tick()[1]:
            return n
    raise ValueError("never ends")
