"""Target faults: what a HAT did that is not a protocol question (silent, dead, rebooted,
garbled, not reading). A case that meets one gets the verdict ``target-fault``, never ``fail``
(conformance/README.md, "Verdicts"), with one line saying what the target did.
"""
from __future__ import annotations

import re
from typing import Any, Optional, Sequence

from ..harness.errors import NeedsCapability, NotReading, TargetCrashed, TargetError

__all__ = ["TargetFault", "is_target_fault", "target_fault_of", "fault_line", "describe_silence",
           "garbled_reply", "first_line", "binary_count", "foreign",
           "SILENT", "DEAD", "REBOOTED", "GARBLED", "NOT_READING", "CRASHED"]

SILENT, DEAD, REBOOTED, GARBLED, NOT_READING = "silent", "dead", "rebooted", "garbled", "not reading"
CRASHED = "crashed"      # the firmware itself crashed (a sil: target: a signal or a sanitizer report)


class TargetFault(Exception):
    """The target misbehaved as a device (not as an implementation of the protocol)."""

    def __init__(self, kind: str, what: str):
        self.kind = kind
        self.what = first_line(what)
        super().__init__(f"target fault ({kind}): {self.what}")


def first_line(text: str, limit: int = 300) -> str:
    """The first non-blank line; one that ends in a colon announces the lines after it (a
    command's last stderr lines), so the last three of those follow on the same line."""
    lines = [line.strip() for line in str(text).splitlines() if line.strip()]
    if not lines:
        return ""
    out = lines[0]
    if out.endswith(":") and len(lines) > 1:
        out += " " + " | ".join(lines[1:][-3:])
    return out[:limit] if len(out) <= limit else out[:limit - 3] + "..."


def is_target_fault(exc: Optional[BaseException]) -> bool:
    """A fault of the target rather than of its protocol: TargetFault, or a harness TargetError
    (gone, not reading) that is not a missing capability (that is a skip)."""
    if exc is None:
        return False
    if isinstance(exc, TargetFault):
        return True
    return isinstance(exc, TargetError) and not isinstance(exc, NeedsCapability)


def target_fault_of(exc: TargetError) -> TargetFault:
    """The target fault for a harness TargetError: it stopped reading, or it is gone."""
    if isinstance(exc, TargetCrashed):
        return TargetFault(CRASHED, str(exc))
    return TargetFault(NOT_READING if isinstance(exc, NotReading) else DEAD, str(exc))


def fault_line(exc: BaseException) -> str:
    """The one line for the report: what the target did."""
    if isinstance(exc, TargetFault):
        return str(exc)
    if isinstance(exc, TargetError):
        return str(target_fault_of(exc))
    return f"target fault ({DEAD}): {first_line(str(exc))}"


_TEXT = bytes(range(0x20, 0x7F)) + b"\r\n"

#: Pieces of the lines a stream prints (data reports docs/FIRMWARE-BEHAVIOUR.md#fb-data-lines, PID
#: and DATA debug #fb-debug).
_STREAM_PIECES = re.compile(r"P[0-3](?:[MC][0-9]+|V):|pv=|sp=|cv=| ie=| de=|DATA mode=|payload=")


def foreign(event: Any) -> bool:
    """A line no Build HAT prints (event kind ``unknown``), not counting stream output with
    bytes missing: the HAT drops output bytes when its TX ring is full
    (docs/FIRMWARE-BEHAVIOUR.md#fb-tx-ring, #fb-debug), so a printable line holding pieces of report
    or PID lines is its own output, cut."""
    if getattr(event, "kind", "") != "unknown":
        return False
    text = str(getattr(event, "text", ""))
    return not (_STREAM_PIECES.search(text) and all(" " <= c <= "~" for c in text))


def binary_count(data: bytes) -> int:
    """Bytes that are not the protocol's text (printable ASCII, CR, LF)."""
    return len(data.translate(None, _TEXT))


def _printable_share(data: bytes) -> float:
    if not data:
        return 1.0
    return 1.0 - binary_count(data) / len(data)


def describe_silence(received: bytes, events: Sequence[Any], waited_s: float) -> TargetFault:
    """The fault for a target that gave no usable answer to the sync: silent, garbage, or
    output that never contains the answer."""
    if not received:
        return TargetFault(SILENT, f"no byte came back in {waited_s:.1f} s (no answer to `version`)")
    if _printable_share(received) < 0.9:
        return TargetFault(GARBLED, f"{len(received):,} bytes of binary garbage and no answer to `version` "
                                    f"in {waited_s:.1f} s")
    unknown = sum(1 for e in events if foreign(e))
    if unknown == 0:
        # Only what a Build HAT prints, then nothing more: it stopped (hung) mid-answer.
        return TargetFault(SILENT, f"{len(events):,} line(s) of Build HAT output, then no answer to "
                                   f"`version` in {waited_s:.1f} s")
    return TargetFault(GARBLED, f"{len(events):,} lines ({unknown:,} of them no Build HAT output) but no "
                                f"answer to `version` in {waited_s:.1f} s")


def garbled_reply(received: bytes) -> TargetFault:
    """The fault for a case whose reply was found only by content: binary garbage on the link,
    or a line ending lost or added."""
    binary = binary_count(received)
    if binary > 16:
        return TargetFault(GARBLED, f"{binary:,} bytes of binary garbage came during this case; the link "
                                    "was resynchronised by content")
    return TargetFault(GARBLED, "the reply to this case's line was garbled on the link (a line ending lost, "
                                "added or corrupted); the link was resynchronised by content")
