"""A last, cheap reduction after Hypothesis's shrinking: drop whole steps from a finding's script.

Hypothesis shrinks the generated program, but on slow targets its shrink phase is cut short by a
time limit. This pass works on the written script instead: it removes one step at a time (a
step is the lines up to and including a fence, or one ``@wait``), replays, and keeps the removal
when the replay still fails the same oracle. It needs a target that starts fresh at every open.
"""
from __future__ import annotations

import time
from typing import Callable, List, Optional, Tuple

from ..harness.script import Action, Script
from ..harness.targets.base import Target
from ..protocol.profiles import Profile
from .link import FENCE
from .oracles import Finding
from .replay import replay_script

__all__ = ["reduce_finding", "steps_of"]


def steps_of(script: Script) -> List[List[Action]]:
    """The script's actions grouped into steps (the first step is the prelude)."""
    steps: List[List[Action]] = []
    current: List[Action] = []
    for action in script.actions:
        current.append(action)
        if action.kind == "wait" or (action.kind == "send" and action.data == FENCE):
            steps.append(current)
            current = []
    if current:
        steps.append(current)
    return steps


def _script(base: Script, steps: List[List[Action]]) -> Script:
    return Script(name=base.name, devices=dict(base.devices), actions=[a for s in steps for a in s],
                  source=base.source, explicit_devices=dict(base.explicit_devices))


def reduce_finding(script: Script, finding: Finding, open_target: Callable[[], Target], profile: Profile,
                   fence_s: float, time_limit: float = 20.0,
                   against: Optional[Tuple[Callable[[], Target], Profile]] = None) -> Tuple[Script, Finding]:
    """The smallest script (by whole steps) that still fails ``finding.oracle``, and its finding."""
    steps = steps_of(script)
    best: Finding = finding
    deadline = time.monotonic() + time_limit
    # Latest steps first. The failing step is not always the last one: inputs sent back to back
    # (pipelined) fail together, so the last step is tried too.
    i = len(steps) - 1
    while i >= 1 and time.monotonic() < deadline:
        trial = steps[:i] + steps[i + 1:]
        again: Optional[Finding] = replay_script(_script(script, trial), open_target, profile, fence_s,
                                                against=against)
        if again is not None and again.oracle == finding.oracle:
            steps, best = trial, again
        i -= 1
    return _script(script, steps), best
