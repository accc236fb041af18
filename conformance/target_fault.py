"""Target faults: what a HAT did that is not a protocol question (silent, dead, rebooted,
garbled, not reading). A case that meets one gets the verdict ``target-fault``, never ``fail``
(TEAM.md standards), with one line saying what the target did.
"""
from __future__ import annotations

from typing import Any, Optional, Sequence

from ..harness.errors import NeedsCapability, TargetError

__all__ = ["TargetFault", "is_target_fault", "fault_line", "describe_silence", "first_line",
           "SILENT", "DEAD", "REBOOTED", "GARBLED", "NOT_READING"]

SILENT, DEAD, REBOOTED, GARBLED, NOT_READING = "silent", "dead", "rebooted", "garbled", "not reading"


class TargetFault(Exception):
    """The target misbehaved as a device (not as an implementation of the protocol)."""

    def __init__(self, kind: str, what: str):
        self.kind = kind
        self.what = first_line(what)
        super().__init__(f"target fault ({kind}): {self.what}")


def first_line(text: str, limit: int = 300) -> str:
    for line in str(text).splitlines():
        if line.strip():
            return line.strip()[:limit]
    return ""


def is_target_fault(exc: Optional[BaseException]) -> bool:
    """A fault of the target rather than of its protocol: TargetFault, or a harness TargetError
    (gone, not reading) that is not a missing capability (that is a skip)."""
    if exc is None:
        return False
    if isinstance(exc, TargetFault):
        return True
    return isinstance(exc, TargetError) and not isinstance(exc, NeedsCapability)


def fault_line(exc: BaseException) -> str:
    """The one line for the report: what the target did."""
    if isinstance(exc, TargetFault):
        return str(exc)
    kind = NOT_READING if "stopped reading" in str(exc) else DEAD
    return f"target fault ({kind}): {first_line(str(exc))}"


def _printable_share(data: bytes) -> float:
    if not data:
        return 1.0
    text = sum(1 for b in data if 0x20 <= b < 0x7F or b in (0x0D, 0x0A))
    return text / len(data)


def describe_silence(received: bytes, events: Sequence[Any], waited_s: float) -> TargetFault:
    """The fault for a target that gave no usable answer to the sync: silent, garbage, or
    output that never contains the answer."""
    if not received:
        return TargetFault(SILENT, f"no byte came back in {waited_s:.1f} s (no answer to `version`)")
    if _printable_share(received) < 0.9:
        return TargetFault(GARBLED, f"{len(received):,} bytes of binary garbage and no answer to `version` "
                                    f"in {waited_s:.1f} s")
    unknown = sum(1 for e in events if getattr(e, "kind", "") == "unknown")
    return TargetFault(GARBLED, f"{len(events):,} lines ({unknown:,} of them no Build HAT output) but no "
                                f"answer to `version` in {waited_s:.1f} s")
