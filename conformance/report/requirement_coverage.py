"""The requirement coverage matrix: every ID of REQUIREMENTS.md against the verdicts of the
tests that cite it. An ID no test cites is a hole; IDs cited but not in the list (``FW-``
firmware facts, typos) are kept apart so they cannot hide a hole."""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Dict, List, Sequence, Tuple

from ...protocol.requirements import Requirement, requirements
from .junit import VERDICTS, Case, JunitRun

__all__ = ["Row", "Coverage", "coverage"]


@dataclass
class Row:
    requirement: Requirement
    cases: List[Tuple[str, Case]] = field(default_factory=list)   # (run label, case)

    @property
    def counts(self) -> Dict[str, int]:
        c = Counter(case.verdict for _run, case in self.cases)
        return {v: c.get(v, 0) for v in VERDICTS}

    @property
    def status(self) -> str:
        """hole (no test) | fail | known_deviation | pass | untested (only skips or information)."""
        c = self.counts
        if not self.cases:
            return "hole"
        if c["fail"]:
            return "fail"
        if c["known_deviation"]:
            return "known_deviation"
        if c["pass"]:
            return "pass"
        return "untested"


@dataclass
class Coverage:
    rows: List[Row]
    other_ids: Dict[str, List[Tuple[str, Case]]]

    @property
    def holes(self) -> List[Row]:
        return [r for r in self.rows if r.status == "hole"]

    def status_counts(self) -> Dict[str, int]:
        return dict(Counter(r.status for r in self.rows))


def coverage(runs: Sequence[JunitRun]) -> Coverage:
    rows = {r.id: Row(r) for r in requirements()}
    other: Dict[str, List[Tuple[str, Case]]] = {}
    for run in runs:
        for case in run.cases:
            for rid in case.requirements:
                if rid in rows:
                    rows[rid].cases.append((run.label, case))
                else:
                    other.setdefault(rid, []).append((run.label, case))
    return Coverage(list(rows.values()), dict(sorted(other.items())))
