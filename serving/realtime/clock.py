"""Wall clock -> virtual milliseconds, ``speed`` times faster than real time, without drift.

The number of ticks due is always computed from the start instant (never by adding up
sleeps), so scheduling jitter never accumulates: after any wall time W the emulator has run
floor(W * 1000 * speed) ticks, give or take the current batch.
"""
from __future__ import annotations

import time
from typing import Callable

__all__ = ["RealTimeClock", "MAX_CATCH_UP_MS"]

# If the process was stopped (e.g. SIGSTOP, a debugger), do not try to run hours of ticks in
# one go: run at most this many per call and let the rest come on later calls.
MAX_CATCH_UP_MS = 2000


class RealTimeClock:
    """Tells a runner how many virtual milliseconds are due at the current wall time."""

    def __init__(self, speed: float = 1.0, now: Callable[[], float] = time.monotonic):
        if not speed > 0:
            raise ValueError(f"speed must be positive, got {speed}")
        self.speed = float(speed)
        self._now = now
        self._start = now()
        self.ticks = 0          # virtual ms run so far

    def set_speed(self, speed: float) -> None:
        """Change the speed from now on (rebases so that no tick is lost or repeated)."""
        if not speed > 0:
            raise ValueError(f"speed must be positive, got {speed}")
        self._start = self._now() - self.ticks / 1000.0 / speed
        self.speed = float(speed)

    def due(self) -> int:
        """Ticks to run now (the caller runs them, then calls :meth:`done`)."""
        return min(self.behind(), MAX_CATCH_UP_MS)

    def behind(self) -> int:
        """Ticks the wall clock is ahead of the ticks run so far (uncapped; 0 if none)."""
        target = int((self._now() - self._start) * 1000.0 * self.speed)
        return max(0, target - self.ticks)

    def skip(self, n: int) -> None:
        """Let ``n`` due ticks never happen: the emulator was not running (a stopped process), so
        that stretch of wall time is lost to the HAT, which from then on runs ``n`` ms behind."""
        self._start += n / 1000.0 / self.speed

    def done(self, n: int) -> None:
        self.ticks += n

    def seconds_until_next(self) -> float:
        """Wall seconds until the next tick is due (0 if one is due already)."""
        return self.seconds_until(1)

    def seconds_until(self, ticks: int) -> float:
        """Wall seconds until the ``ticks``-th tick from now is due (0 if it is due already)."""
        next_at = self._start + (self.ticks + ticks) / 1000.0 / self.speed
        return max(0.0, next_at - self._now())
