"""Shrinking a finding by replaying smaller scripts: whole steps first, then single lines.

A step is the lines up to and including a fence, or one ``@wait`` between steps; the first step is the
prelude and stays. A removal is kept when the replay still fails the same oracle. This works on
every target the fuzzer can drive, real ones included: it needs nothing but replays (which bring
the target to a known state with the prelude).
"""
from __future__ import annotations

import time
from typing import Callable, List, Optional, Tuple

from ...transcripts.script import Action, Script
from ..oracles.registry import Finding
from ..running.target_exchange import FENCE

__all__ = ["reduce_finding", "steps_of"]

Replay = Callable[[Script], Optional[Finding]]


def steps_of(script: Script) -> List[List[Action]]:
    """The script's actions grouped into steps (the first step is the prelude)."""
    steps: List[List[Action]] = []
    current: List[Action] = []
    for action in script.actions:
        current.append(action)
        # A wait inside a step (sends before it, its fence after) is the step's own pause.
        if (action.kind == "wait" and not any(a.kind == "send" for a in current)) or \
                (action.kind == "send" and action.data == FENCE):
            steps.append(current)
            current = []
    if current:
        steps.append(current)
    return steps


def _script(base: Script, steps: List[List[Action]]) -> Script:
    return Script(name=base.name, devices=dict(base.devices), actions=[a for s in steps for a in s],
                  source=base.source, explicit_devices=dict(base.explicit_devices))


def reduce_finding(script: Script, finding: Finding, replay: Replay, time_limit: float = 30.0,
                   on_smaller: Optional[Callable[[Script, Finding], None]] = None) -> Tuple[Script, Finding]:
    """The smallest script found (by whole steps, then lines) that still fails ``finding.oracle``,
    and the finding its replay gave (``finding`` itself when nothing could be removed).
    ``on_smaller`` is told each smaller failing script as it is found (what an interrupt leaves)."""
    steps = steps_of(script)
    best: Finding = finding
    deadline = time.monotonic() + time_limit

    def fails(trial: List[List[Action]]) -> Optional[Finding]:
        again = replay(_script(script, trial))
        if again is None or again.oracle != finding.oracle or again.details.get("prelude"):
            return None
        return again

    # Whole steps, latest first: the failing step is usually the last, and what sets its scene
    # comes shortly before it.
    i = len(steps) - 1
    while i >= 1 and time.monotonic() < deadline:
        trial = steps[:i] + steps[i + 1:]
        again = fails(trial)
        if again is not None:
            steps, best = trial, again
            if on_smaller is not None:
                on_smaller(_script(script, steps), best)
        i -= 1
    # Then the lines of each remaining step (never its fence: it ends the step).
    for i in range(len(steps) - 1, 0, -1):
        j = len(steps[i]) - 1
        while j >= 0 and time.monotonic() < deadline:
            action = steps[i][j]
            if action.kind == "send" and action.data != FENCE and len(steps[i]) > 2:
                trial = steps[:i] + [steps[i][:j] + steps[i][j + 1:]] + steps[i + 1:]
                again = fails(trial)
                if again is not None:
                    steps, best = trial, again
                    if on_smaller is not None:
                        on_smaller(_script(script, steps), best)
            j -= 1
    return _script(script, steps), best
