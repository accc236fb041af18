"""The fuzzer's own oracles, in the JUnit file's order (fuzz/oracles/registry.py). Their checks run where
the runner reads an answer (fuzz/running/checked_run.py): the model's prediction matched in
stream_match.py (``fate``, ``hygiene``, the ``state`` of prompts and echo), the state in state_check.py,
the fence's deadline in target_exchange.py (``liveness``), the two sides compared in differential.py,
a firmware in the loop's reports in sil/sanitizer_reports.py (``crash``, ``sanitizer``)."""
from __future__ import annotations

from .registry import WHERE_CHECKED, WITH_AGAINST, Oracle, register

__all__ = ["LIVENESS", "FATE", "STATE", "HYGIENE", "DIFFERENTIAL", "CRASH", "SANITIZER"]

# What each checks, as `fuzz --help` says it.
_HELP = {
    "liveness": "every step's fence answers within its deadline, and no start-up banner (a reboot) comes",
    "fate": "each line's answer (Error or not, the output of every command that ran) is the one the "
            "reference model predicts from the facts",
    "state": "the prompt, the echo, the data reports (only from ports whose selection allows them, in the "
             "form it asks for) and the drive duty show the state the model tracks",
    "hygiene": "every output line is of a class this release prints in this state, none left half-printed",
    "differential": "with --against: both targets answer the same input alike (analogue values within a "
                    "tolerance)",
    "crash": "a firmware in the loop (sil:) does not die while it takes the input",
    "sanitizer": "a firmware in the loop (sil:) reports no sanitizer error",
}

# Priority: of two problems in one answer, a reboot or a dead link says most, then a line of no known
# class, then a wrong answer, then the state it shows. A firmware in the loop (sil:) that died, or went
# on after a sanitizer report: only the firmware's doing, a case where it is checked.
LIVENESS = register(Oracle("liveness", _HELP["liveness"], priority=0, target_lost=True))
FATE = register(Oracle("fate", _HELP["fate"], priority=2, per_answer=True))
STATE = register(Oracle("state", _HELP["state"], priority=3, per_answer=True))
HYGIENE = register(Oracle("hygiene", _HELP["hygiene"], priority=1, per_answer=True))
DIFFERENTIAL = register(Oracle("differential", _HELP["differential"], priority=4, case=WITH_AGAINST))
CRASH = register(Oracle("crash", _HELP["crash"], priority=5, case=WHERE_CHECKED, target_lost=True))
SANITIZER = register(Oracle("sanitizer", _HELP["sanitizer"], priority=6, case=WHERE_CHECKED))
