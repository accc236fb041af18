"""The stateful fuzzer: a Hypothesis ``RuleBasedStateMachine`` that drives one target (two in
differential mode) with grammar-generated input, checking the oracles after every step.

Rules (what a host can do): send one input; send several back to back (pipelined, to keep a slow
link busy); let HAT time pass. The model (fuzz/model.py) follows every byte sent, so after each
step the oracles compare what the target printed with what the facts predict (fuzz/runner.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Tuple

import hypothesis
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, precondition, rule

from ..harness.targets.base import Target
from ..protocol.profiles import Profile
from .grammar import grammar_for
from .runner import Runner, Stats, guard_debug
from .strategies import FAMILIES, FuzzInput, fuzz_input

__all__ = ["FuzzConfig", "make_machine"]


@dataclass
class FuzzConfig:
    open_primary: Callable[[], Target]
    profile: Profile
    open_secondary: Optional[Callable[[], Target]] = None
    secondary_profile: Optional[Profile] = None
    families: Tuple[str, ...] = FAMILIES
    batch: int = 4                # >1: also send up to this many inputs back to back (pipelining)
    waits: Tuple[int, ...] = (10, 60, 300)
    fence_s: float = 2.0
    fresh: bool = True            # each run starts from a freshly booted HAT (combi tables known)
    labels: Tuple[str, str] = ("target", "against")
    devices: Optional[Dict[int, Optional[tuple]]] = None   # the layout, when known
    stats: Stats = field(default_factory=Stats)


def make_machine(config: FuzzConfig) -> type:
    """A RuleBasedStateMachine class bound to ``config``."""
    inputs = fuzz_input(grammar_for(config.profile), config.families)
    stats = config.stats

    class BuildHatMachine(RuleBasedStateMachine):
        def __init__(self) -> None:
            super().__init__()
            stats.examples += 1
            openers = [(config.labels[0], config.open_primary, config.profile)]
            if config.open_secondary is not None:
                openers.append((config.labels[1], config.open_secondary,
                                config.secondary_profile or config.profile))
            self.runner = Runner(openers, config.fence_s, config.fresh, stats, config.devices)
            try:
                self.runner.start()
            except BaseException:
                self.runner.close()
                raise

        @rule(inp=inputs)
        def send(self, inp: FuzzInput) -> None:
            self._send([inp])

        @precondition(lambda self: config.batch > 1)
        @rule(batch=st.lists(inputs, min_size=2, max_size=max(2, config.batch)))
        def send_pipelined(self, batch: List[FuzzInput]) -> None:
            self._send(batch)

        @precondition(lambda self: bool(config.waits))
        @rule(ms=st.sampled_from(config.waits or (0,)))
        def wait(self, ms: int) -> None:
            self.runner.wait(ms)

        def teardown(self) -> None:
            hypothesis.target(float(len(self.runner.kinds_seen)), label="response classes in this run")
            self.runner.close()

        def _send(self, batch: List[FuzzInput]) -> None:
            # The debug guard is decided on the first side's model and applied to every side,
            # so all targets receive identical bytes.
            datas, ahead = guard_debug(self.runner.sides[0].model, [inp.data for inp in batch])
            for inp, data in zip(batch, datas):
                stats.executions += 1
                stats.lines += data.count(b"\r")
                stats.productions.update(inp.productions)
                hypothesis.event(f"family {inp.family}")
                for prod in inp.productions:
                    hypothesis.event(f"production {prod}")
            before = set(self.runner.kinds_seen)
            self.runner.exchange(datas, ahead)
            for kind in sorted(self.runner.kinds_seen - before):
                hypothesis.event(f"response {kind}")
            if stats.on_progress is not None:
                stats.on_progress(stats)

    BuildHatMachine.__name__ = f"BuildHatMachine_{config.profile.name}"
    return BuildHatMachine
