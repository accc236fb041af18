"""The fuzzer's oracles, each a named check reported on its own (one JUnit entry each).

- ``liveness``: after every fuzzed input a fence answers within its deadline, and no start-up
  banner appears (an unexpected reboot).
- ``fate``: the reference model (fuzz/model/reference_model.py) predicts each line's answer: ``Error`` or not
and
  the output of every command that ran; the target must agree.
- ``state``: the state the model tracks shows in observable effects: the prompt (port, echo),
  the echo of edited lines, data reports only from ports whose selection allows them and in the
  form the selection asks for (``M``/``C``/``V``), once-selections reporting once.
- ``hygiene``: every output line is of a known class for the release, nothing is left half-printed
  or interleaved mid-line.
- ``differential`` (with ``--against``): two targets given the same input answer the same, with
  tolerance for analogue values.

A failed check raises the oracle's own :class:`Finding` subclass, so Hypothesis shrinks each kind
of failure separately and keeps one minimal example per oracle.
"""
from __future__ import annotations

from typing import Dict, List, Optional, Type

__all__ = ["ORACLES", "Finding", "finding_class", "raise_finding"]

# crash: a firmware in the loop died (a signal, a sanitizer report it cannot go on after);
# sanitizer: it went on after a sanitizer report (sil/sanitizer_reports.py). Either can only be the
# firmware's doing.
ORACLES = ("liveness", "fate", "state", "hygiene", "differential", "crash", "sanitizer")


class Finding(AssertionError):
    """A failed oracle. ``traces`` holds what crossed each link in the failing run."""

    oracle = "finding"

    def __init__(self, message: str, traces: Optional[list] = None, details: Optional[dict] = None):
        super().__init__(f"[{self.oracle}] {message}")
        self.message = message
        self.traces = traces or []
        self.details = details or {}


def _make(name: str) -> Type[Finding]:
    return type(f"{name.capitalize()}Finding", (Finding,), {"oracle": name, "__module__": __name__})


_CLASSES: Dict[str, Type[Finding]] = {name: _make(name) for name in ORACLES}
LivenessFinding = _CLASSES["liveness"]
FateFinding = _CLASSES["fate"]
StateFinding = _CLASSES["state"]
HygieneFinding = _CLASSES["hygiene"]
DifferentialFinding = _CLASSES["differential"]
CrashFinding = _CLASSES["crash"]            # (module attributes: a --jobs worker pickles them)
SanitizerFinding = _CLASSES["sanitizer"]


def finding_class(oracle: str) -> Type[Finding]:
    try:
        return _CLASSES[oracle]
    except KeyError:
        raise ValueError(f"unknown oracle {oracle!r} (known: {', '.join(ORACLES)})") from None


def raise_finding(oracle: str, message: str, traces: List, details: Optional[dict] = None) -> None:
    raise finding_class(oracle)(message, traces, details)
