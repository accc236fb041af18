"""A campaign's budgets: how long it fuzzes (``--budget``: wall-clock time or a number of runs), and
how long it may spend checking its findings (``--check-time``: confirming and reducing them).

Checking does not count as fuzzing time, so without a bound of its own a campaign could spend any
time after its budget replaying findings. A time budget therefore bounds checking to a share of
it by default; a run budget has no wall clock to take a share of, and each finding's checking is
bounded there by its replays (``--confirm``) and ``--shrink-time``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Optional

__all__ = ["Budget", "parse_budget", "parse_seconds", "check_limit", "CHECK_SHARE"]

CHECK_SHARE = 0.25      # of a time budget: the default bound on the time spent checking findings


@dataclass(frozen=True)
class Budget:
    seconds: Optional[float] = None
    examples: Optional[int] = None

    def __str__(self) -> str:
        return f"{self.seconds:g}s" if self.seconds is not None else f"{self.examples}x"


_BUDGET = re.compile(r"\s*(\d+(?:\.\d+)?)\s*(s|m|h|x)\s*")
_SECONDS = {"s": 1, "m": 60, "h": 3600}


def parse_budget(text: str) -> Budget:
    """``60s``, ``2m``, ``1h`` (wall clock) or ``500x`` (runs). A bare number is refused."""
    m = _BUDGET.fullmatch(str(text))
    if not m:
        hint = f" (say {text.strip()}s for seconds or {text.strip()}x for runs)" if re.fullmatch(
            r"\s*\d+(\.\d+)?\s*", str(text)) else ""
        raise ValueError(f"--budget takes a duration (60s, 2m, 1h) or a number of runs (500x), "
                         f"got {text!r}{hint}")
    value, unit = float(m.group(1)), m.group(2)
    if unit == "x":
        if value != int(value) or value < 1:
            raise ValueError(f"a run budget must be a positive whole number, got {text!r}")
        return Budget(examples=int(value))
    if value <= 0:
        raise ValueError(f"a time budget must be more than zero, got {text!r}")
    return Budget(seconds=value * _SECONDS[unit])


def parse_seconds(text: str, option: str) -> float:
    """A duration of zero or more: ``90``/``90s``, ``2m``, ``1h`` (a bare number is seconds, as
    ``--shrink-time`` takes it)."""
    m = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*(s|m|h)?\s*", str(text))
    if not m:
        raise ValueError(f"{option} takes a duration (90s, 2m, 1h; a bare number is seconds), got {text!r}")
    return float(m.group(1)) * _SECONDS[m.group(2) or "s"]


def check_limit(budget: Budget, given: Optional[str]) -> Optional[float]:
    """Seconds the campaign may spend checking findings: ``given`` (``--check-time``), else a share
    of a time budget; None (no bound beyond each finding's own) for a run budget."""
    if given is not None:
        return parse_seconds(given, "--check-time")
    return None if budget.seconds is None else budget.seconds * CHECK_SHARE
