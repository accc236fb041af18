"""Replaying a finding's script with the fuzzer's own oracles: does it fail the same way?

The script's sends are grouped as the fuzzer sent them: every group ends with the fence line
(``version``) and is one step; the first group is the prelude, which is not judged. ``@wait``
lets HAT time pass (checked like the fuzzer's wait rule); world actions go to the target's control.
"""
from __future__ import annotations

from typing import Callable, List, Optional, Tuple, Union

from ...harness.targets.base import Target
from ...protocol.profiles import Profile
from ...transcripts.script import Script, load_script
from ..oracles.registry import Finding
from ..running.checked_run import Runner
from ..running.target_exchange import FENCE

__all__ = ["replay_script"]


def replay_script(script: Union[str, Script], open_target: Callable[[], Target], profile: Profile,
                  fence_s: float = 2.0, fresh: bool = True,
                  against: Optional[Tuple[Callable[[], Target], Profile]] = None, keep_open: bool = False,
                  on_fail: Optional[Callable[[Finding], None]] = None,
                  tx_ring: Union[bool, Tuple[bool, ...]] = False) -> Optional[Finding]:
    """The finding the replay produces (None if every check passed). With ``against`` (an opener
    and its release) the script goes to both targets and the differential oracle runs too.
    ``keep_open``: the openers hand out targets that stay open after the replay (``on_fail`` is
    called with the finding of a failed replay, which may have left them broken). ``tx_ring``:
    as :class:`~.runner.Runner`; a ``@wait`` between a step's lines and its fence is the pause that
    let a full TX ring drain, and is kept there (a step without one pauses as the runner reckons)."""
    if not isinstance(script, Script):
        script = load_script(script)
    runner: Optional[Runner] = None
    pending: List[bytes] = []
    started = False
    try:
        openers = [("target", open_target, profile)]
        if against is not None:
            openers.append(("against", against[0], against[1]))
        layout = dict(script.devices) if script.explicit_devices else None
        runner = Runner(openers, fence_s, fresh, devices=layout, keep_open=keep_open, tx_ring=tx_ring)
        pause: Optional[int] = None
        for action in script.actions:
            if action.kind == "send":
                if action.data != FENCE:
                    pending.append(action.data)
                    continue
                blob = b"".join(pending)
                pending = []
                if not started:
                    runner.start(blob)
                    started = True
                else:
                    runner.exchange([blob], pause_ms=pause)
                pause = None
            elif action.kind == "wait":
                if pending:
                    pause = (pause or 0) + int(action.args[0])     # before this step's fence
                elif started:
                    runner.wait(int(action.args[0]))
            else:
                for side in runner.sides:
                    control = side.link.target.control
                    if control is None:
                        raise ValueError(f"line {action.lineno}: {action.text} needs a target with a control")
                    control.action(action.text)
    except Finding as finding:
        if on_fail is not None:
            on_fail(finding)
        return finding
    finally:
        if runner is not None:
            runner.close()
    return None
