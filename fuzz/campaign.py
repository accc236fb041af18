"""A fuzzing campaign: runs the state machine under a budget, collects one shrunk finding per oracle.

The budget is wall-clock seconds (``30s``, ``2m``) or a number of examples (``5000``). The machine
runs in chunks of examples; each chunk is one Hypothesis run with its own seed derived from
``--seed``, so a campaign with an example budget is reproducible. The Hypothesis database (when
given) persists failing examples between campaigns: the next run replays them first.
A campaign stops after the first chunk that produced findings (each one already shrunk).
"""
from __future__ import annotations

import hashlib
import re
import time
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Tuple

import hypothesis
from hypothesis import HealthCheck, Verbosity, settings
from hypothesis.database import DirectoryBasedExampleDatabase
from hypothesis.stateful import get_state_machine_test

from .machine import FuzzConfig, make_machine
from .oracles import Finding

__all__ = ["Budget", "parse_budget", "CampaignResult", "run_campaign"]


@dataclass(frozen=True)
class Budget:
    seconds: Optional[float] = None
    examples: Optional[int] = None

    def __str__(self) -> str:
        return f"{self.seconds:g}s" if self.seconds is not None else f"{self.examples} examples"


def parse_budget(text: str) -> Budget:
    """``30s``, ``2m``, ``1h`` (wall-clock) or ``5000`` (examples)."""
    m = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*(s|m|h)?\s*", str(text))
    if not m:
        raise ValueError(f"budget must be a duration like 30s / 2m or a number of examples, got {text!r}")
    value, unit = float(m.group(1)), m.group(2)
    if unit is None:
        if value != int(value) or value < 1:
            raise ValueError(f"an example budget must be a positive whole number, got {text!r}")
        return Budget(examples=int(value))
    return Budget(seconds=value * {"s": 1, "m": 60, "h": 3600}[unit])


@dataclass
class CampaignResult:
    findings: List[Finding] = field(default_factory=list)
    flaky: List[str] = field(default_factory=list)
    elapsed: float = 0.0
    chunks: int = 0
    seed: Optional[int] = None

    def finding(self, oracle: str) -> Optional[Finding]:
        return next((f for f in self.findings if f.oracle == oracle), None)


def _flatten(exc: BaseException) -> List[BaseException]:
    inner = getattr(exc, "exceptions", None)
    if inner:
        out: List[BaseException] = []
        for e in inner:
            out.extend(_flatten(e))
        return out
    return [exc]


def _chunk_seed(seed: int, index: int) -> int:
    return int.from_bytes(hashlib.sha256(f"{seed}:{index}".encode()).digest()[:8], "big")


def run_campaign(config: FuzzConfig, budget: Budget, seed: Optional[int] = None,
                 database: Optional[str] = None, steps: int = 20, chunk: int = 25,
                 database_key: str = "", stop: Optional[Callable[[], bool]] = None,
                 shrink_seconds: Optional[float] = None) -> CampaignResult:
    """Run the machine until the budget is spent or findings appear.

    ``shrink_seconds`` caps Hypothesis's shrink phase (on a slow target it would otherwise run for
    up to 5 minutes per finding); fuzz/reduce.py finishes the job on the written script.
    """
    limit = _ShrinkLimit(shrink_seconds)
    machine = make_machine(config)
    result = CampaignResult(seed=seed)
    start = time.monotonic()
    done = 0
    if budget.seconds is not None:
        chunk = min(chunk, 5)     # the first chunk measures the pace
    db = DirectoryBasedExampleDatabase(database) if database else None
    while True:
        if budget.examples is not None and done >= budget.examples:
            break
        if budget.seconds is not None and time.monotonic() - start >= budget.seconds:
            break
        if stop is not None and stop():
            break
        n = chunk if budget.examples is None else min(chunk, budget.examples - done)
        if budget.seconds is not None and done:
            # Size the chunk to what is left of the time budget (Hypothesis cannot be stopped
            # mid-run), from the time an example has taken so far.
            per_example = (time.monotonic() - start) / done
            left = budget.seconds - (time.monotonic() - start)
            n = max(1, min(chunk, int(left / max(per_example, 1e-3))))
        test = get_state_machine_test(machine, settings=settings(
            max_examples=n, stateful_step_count=steps, deadline=None, database=db,
            # HealthCheck iterates via an untyped metaclass __iter__: pyright cannot see its members
            suppress_health_check=list(HealthCheck),  # pyright: ignore[reportArgumentType]
            verbosity=Verbosity.quiet, report_multiple_bugs=True,
            print_blob=False))
        # One key per target kind, release and input families: examples saved for one campaign
        # are replayed by the next campaign of the same kind.
        test._hypothesis_internal_database_key = hashlib.sha256(  # type: ignore[attr-defined]
            f"buildhat-fuzz:{database_key}:{config.profile.name}:{','.join(config.families)}".encode()
        ).digest()
        if seed is not None:
            test = hypothesis.seed(_chunk_seed(seed, result.chunks))(test)
        result.chunks += 1
        if budget.seconds is not None and shrink_seconds is not None:
            # A time budget bounds shrinking too (but leave it a few seconds to work with).
            limit.seconds = min(shrink_seconds, max(5.0, budget.seconds - (time.monotonic() - start)))
        try:
            with limit:
                test()
        except BaseException as exc:  # noqa: B036 - Hypothesis groups failures; we sort them below
            if isinstance(exc, KeyboardInterrupt):
                raise
            found = _flatten(exc)
            for e in found:
                if isinstance(e, Finding):
                    if result.finding(e.oracle) is None:
                        result.findings.append(e)
                    if "Flaky" in type(exc).__name__:
                        result.flaky.append(e.oracle)
            others = [e for e in found if not isinstance(e, Finding)]
            if others and not result.findings:
                raise others[0] from None
            if result.findings:
                break
        finally:
            done += n
    result.elapsed = time.monotonic() - start
    return result


class _ShrinkLimit:
    """Temporarily lowers Hypothesis's shrink-time cap (an engine constant; no public setting)."""

    def __init__(self, seconds: Optional[float]):
        self.seconds = seconds
        self.saved: Optional[float] = None

    def __enter__(self) -> None:
        from hypothesis.internal.conjecture import engine
        if self.seconds is not None and hasattr(engine, "MAX_SHRINKING_SECONDS"):
            self.saved = engine.MAX_SHRINKING_SECONDS
            engine.MAX_SHRINKING_SECONDS = self.seconds

    def __exit__(self, *exc) -> None:
        from hypothesis.internal.conjecture import engine
        if self.saved is not None:
            engine.MAX_SHRINKING_SECONDS = self.saved
            self.saved = None


def describe(result: CampaignResult) -> Tuple[str, ...]:
    return tuple(f"{f.oracle}: {f.message}" for f in result.findings)
