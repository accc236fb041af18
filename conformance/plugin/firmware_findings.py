"""A firmware in the loop's own defects, found by the sanitizers (or a crash), in a conformance run.

On a target that runs the firmware itself (``sil:``, capability ``firmware_reports``) a crash or a
sanitizer report can only be the firmware's doing: there is no power supply to fail. So it is not
a target fault: the case that met it fails with the report's first line as its message, the
whole report goes in the case's transcript, a crashed firmware is started again (a fresh HAT,
the suite's set-up restored by the next case's fence) and the run goes on. Each distinct report
(kind, file, line) is listed once with the cases that met it: on the terminal's closing lines
and, through the JUnit property ``firmware_defects`` (JSON), on the report's first screen.
Reports covered by the run's suppressions file (sil/sanitizer_reports.py) are listed as
suppressed and fail nothing. A real HAT keeps its target faults: there a restart can be the power.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

__all__ = ["FirmwareFindings", "Defect", "PROPERTY"]

PROPERTY = "firmware_defects"
# Cases named per defect on the terminal (the JUnit property has them all).
CASES_SHOWN = 3


@dataclass
class Defect:
    kind: str
    file: str
    line: int
    first: str                         # the first report's first line
    suppressed_by: Optional[str] = None
    cases: List[str] = field(default_factory=list)
    times: int = 0

    @property
    def where(self) -> str:
        return f"{self.file}:{self.line}" if self.file else "(no source line)"

    def as_dict(self) -> Dict[str, Any]:
        return {"kind": self.kind, "file": self.file, "line": self.line, "first": self.first,
                "suppressed_by": self.suppressed_by, "cases": self.cases, "times": self.times}


class FirmwareFindings:
    """The defects of one run, by (kind, file, line), in the order first met."""

    def __init__(self) -> None:
        self.defects: Dict[Tuple[str, str, int], Defect] = {}

    @staticmethod
    def target_of(tee: Any) -> Any:
        """The target behind the run's tee when it runs the firmware itself, else None."""
        inner = getattr(tee, "inner", None)
        return inner if inner is not None and hasattr(inner, "take_firmware_reports") else None

    def take(self, tee: Any, nodeid: str) -> List[Any]:
        """The firmware's reports since the last look, recorded for ``nodeid`` and written (whole)
        into the transcript now being written."""
        target = self.target_of(tee)
        if target is None:
            return []
        found = list(target.take_firmware_reports())
        for report in found:
            tee.note(report.text if report.suppressed_by is None
                     else f"(suppressed by {report.suppressed_by})\n{report.text}")
            defect = self.defects.get(report.key)
            if defect is None:
                defect = Defect(report.kind, report.file, report.line, report.first, report.suppressed_by)
                self.defects[report.key] = defect
            defect.times += 1
            if nodeid not in defect.cases:
                defect.cases.append(nodeid)
        return found

    def as_property(self) -> str:
        return json.dumps([d.as_dict() for d in self.defects.values()])

    def lines(self) -> List[Tuple[str, bool]]:
        """The terminal's closing lines: (text, whether it failed something)."""
        if not self.defects:
            return []
        found = [d for d in self.defects.values() if d.suppressed_by is None]
        quiet = [d for d in self.defects.values() if d.suppressed_by is not None]
        out = [(f"firmware defects found by the sanitizers: {len(found)}"
                + (f" (and {len(quiet)} suppressed)" if quiet else ""), bool(found))]
        for d in found + quiet:
            cases = ", ".join(d.cases[:CASES_SHOWN]) + (f" and {len(d.cases) - CASES_SHOWN} more"
                                                         if len(d.cases) > CASES_SHOWN else "")
            tag = f"suppressed ({d.suppressed_by})" if d.suppressed_by else f"{len(d.cases)} case(s)"
            out.append((f"  {d.kind} at {d.where}, {tag}: {d.first} [{cases}]", d.suppressed_by is None))
        return out
