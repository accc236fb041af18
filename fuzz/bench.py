"""Fuzzing throughput, for ``make bench`` (never asserted in tests).

:func:`measure_throughput` answers "how many fuzzed lines per second, with every oracle on, does
this target take?" It opens the target once, sends the prelude, then sends a fixed, seeded pool of
generated inputs in pipelined batches (each input followed by its fence) for ``seconds`` and
counts. Start-up, Hypothesis's own generation and shrinking are outside the timed part, so the
figure is the link's steady state:

    from .bench import measure_throughput
    measure_throughput("inprocess")                 # the emulator in this process, virtual time
    measure_throughput("emulator:R7", batch=8)      # buildhat-emulator on a pty, real time
    measure_throughput("/dev/serial0", batch=8)     # a real HAT (its state is reset by the prelude)

Returns a dict: ``lines``, ``inputs``, ``seconds``, ``lines_per_s``, ``inputs_per_s``, ``findings``
(oracle failures seen; the run restarts the target after each), ``url``, ``batch``.
"""
from __future__ import annotations

import time
from typing import Callable, Dict, List, Optional, Tuple

from hypothesis import HealthCheck, Phase, given, seed, settings

from ..harness.targets import make_target
from ..harness.targets.base import Target
from ..protocol.profiles import Profile
from .grammar import grammar_for
from .oracles import Finding
from .runner import Runner, guard_debug
from .strategies import FAMILIES, FuzzInput, fuzz_input

__all__ = ["measure_throughput", "input_pool"]


def input_pool(profile: Profile, n: int = 400, seed_value: int = 0,
               families: Tuple[str, ...] = FAMILIES) -> List[FuzzInput]:
    """``n`` generated inputs, the same for the same seed."""
    pool: List[FuzzInput] = []

    # HealthCheck iterates via an untyped metaclass __iter__: pyright cannot see its members
    @settings(max_examples=n, database=None, phases=[Phase.generate], deadline=None,
              suppress_health_check=list(HealthCheck))  # pyright: ignore[reportArgumentType]
    @given(fuzz_input(grammar_for(profile), families))
    def collect(inp: FuzzInput) -> None:
        pool.append(inp)

    seed(seed_value)(collect)()
    return pool[:n]


def measure_throughput(url: str = "inprocess", seconds: float = 5.0, batch: int = 8, seed_value: int = 0,
                       profile: Optional[Profile] = None, fence_s: Optional[float] = None,
                       families: Tuple[str, ...] = FAMILIES) -> Dict[str, object]:
    """Fuzzed lines per second on ``url`` with every oracle checking (see the module docstring)."""
    from .cli import detect_profile, is_fresh
    opener: Callable[[], Target] = lambda: make_target(url)  # noqa: E731
    profile = profile or detect_profile(opener)
    fence = fence_s if fence_s is not None else (0.3 if url.startswith("inprocess") else 2.0)
    pool = input_pool(profile, 400, seed_value, families)
    lines = inputs = findings = 0
    runner = _start(opener, profile, fence, is_fresh(url))
    start = time.monotonic()
    i = 0
    try:
        while time.monotonic() - start < seconds:
            chunk = [pool[(i + k) % len(pool)].data for k in range(batch)]
            i += batch
            datas, ahead = guard_debug(runner.sides[0].model, chunk)
            try:
                runner.exchange(datas, ahead)
            except Finding:
                findings += 1
                runner.close()
                runner = _start(opener, profile, fence, is_fresh(url))
            inputs += len(datas)
            lines += sum(d.count(b"\r") for d in datas)
    finally:
        runner.close()
    elapsed = time.monotonic() - start
    return {"url": url, "batch": batch, "lines": lines, "inputs": inputs, "seconds": round(elapsed, 3),
            "lines_per_s": round(lines / elapsed, 1), "inputs_per_s": round(inputs / elapsed, 1),
            "findings": findings}


def _start(opener: Callable[[], Target], profile: Profile, fence_s: float, fresh: bool) -> Runner:
    runner = Runner([("target", opener, profile)], fence_s, fresh)
    runner.start()
    return runner
