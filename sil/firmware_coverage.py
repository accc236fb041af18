"""The firmware's line and branch coverage from a ``--coverage`` build, summarised by gcovr.

gcov counts are written into the build folder when the firmware program exits (the sil
target lets it exit cleanly at the end of a run or campaign), and add up over runs:
:func:`reset_counts` clears them for one run's figure. gcovr (a well-kept coverage tool that
reads gcov data for a whole tree) does the counting; this module only asks it and keeps, per
firmware file, the percentages and the lines never reached.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional

from .build import Build

__all__ = ["FileCoverage", "CoverageSummary", "coverage_summary", "reset_counts", "gcovr_command"]


@dataclass
class FileCoverage:
    name: str
    lines_covered: int
    lines_total: int
    branches_covered: int
    branches_total: int
    missed_lines: List[int] = field(default_factory=list)

    @property
    def line_percent(self) -> float:
        return 100.0 * self.lines_covered / self.lines_total if self.lines_total else 100.0

    @property
    def branch_percent(self) -> float:
        return 100.0 * self.branches_covered / self.branches_total if self.branches_total else 100.0


@dataclass
class CoverageSummary:
    files: List[FileCoverage]

    def _sum(self, attr: str) -> int:
        return sum(getattr(f, attr) for f in self.files)

    @property
    def line_percent(self) -> float:
        total = self._sum("lines_total")
        return 100.0 * self._sum("lines_covered") / total if total else 0.0

    @property
    def branch_percent(self) -> float:
        total = self._sum("branches_total")
        return 100.0 * self._sum("branches_covered") / total if total else 0.0

    def text(self) -> str:
        rows = [f"firmware coverage: lines {self.line_percent:.1f}% ({self._sum('lines_covered')}/"
                f"{self._sum('lines_total')}), branches {self.branch_percent:.1f}%"]
        for f in self.files:
            rows.append(f"  {f.name:<14} lines {f.line_percent:5.1f}%  branches {f.branch_percent:5.1f}%"
                        f"  never reached: {_ranges(f.missed_lines) or '-'}")
        return "\n".join(rows)

    def as_dict(self) -> Dict[str, object]:
        return {"line_percent": round(self.line_percent, 2), "branch_percent": round(self.branch_percent, 2),
                "files": [{"name": f.name, "lines_covered": f.lines_covered, "lines_total": f.lines_total,
                           "branches_covered": f.branches_covered, "branches_total": f.branches_total,
                           "line_percent": round(f.line_percent, 2),
                           "branch_percent": round(f.branch_percent, 2),
                           "missed_lines": f.missed_lines} for f in self.files]}


def _ranges(lines: List[int]) -> str:
    out: List[str] = []
    start = prev = None
    for n in lines:
        if prev is not None and n == prev + 1:
            prev = n
            continue
        if start is not None:
            out.append(str(start) if start == prev else f"{start}-{prev}")
        start = prev = n
    if start is not None:
        out.append(str(start) if start == prev else f"{start}-{prev}")
    return ",".join(out)


def gcovr_command() -> List[str]:
    found = shutil.which("gcovr") or shutil.which("gcovr", path=os.path.dirname(sys.executable))
    if found:
        return [found]
    return [sys.executable, "-m", "gcovr"]


def reset_counts(build: Build) -> None:
    for gcda in Path(build.folder).glob("*.gcda"):
        gcda.unlink()


def coverage_summary(build: Build, html: Optional[str] = None) -> CoverageSummary:
    """Ask gcovr for the counts of ``build`` (a ``--coverage`` build that has run)."""
    if not list(Path(build.folder).glob("*.gcno")):
        raise RuntimeError(f"{build.program} was not built with --coverage")
    if not list(Path(build.folder).glob("*.gcda")):
        raise RuntimeError("no coverage counts yet: run something against the target first")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "coverage.json"
        cmd = gcovr_command() + ["-r", str(build.tree), str(build.folder), "--json", str(out)]
        if html:
            cmd += ["--html-details", html]
        try:
            done = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, timeout=300)
        except FileNotFoundError:
            raise RuntimeError("gcovr is not installed: pip install gcovr "
                               "(or pip install 'buildhat-conformance[sil]')") from None
        if done.returncode != 0 or not out.exists():
            err = (done.stderr.strip().splitlines() or ["gcovr failed"])[-1]
            if "No module named gcovr" in done.stderr:
                err = "gcovr is not installed: pip install gcovr (or pip install 'buildhat-conformance[sil]')"
            raise RuntimeError(err)
        data = json.loads(out.read_text(encoding="utf-8"))
    files: List[FileCoverage] = []
    for entry in data.get("files", []):
        lines = [ln for ln in entry.get("lines", []) if not ln.get("gcovr/noncode")]
        counted: Dict[int, int] = {}
        for ln in lines:
            counted[ln["line_number"]] = max(counted.get(ln["line_number"], 0), ln.get("count", 0))
        branches = [b for ln in lines for b in ln.get("branches", [])]
        files.append(FileCoverage(
            name=os.path.basename(entry["file"]),
            lines_covered=sum(1 for c in counted.values() if c > 0), lines_total=len(counted),
            branches_covered=sum(1 for b in branches if b.get("count", 0) > 0), branches_total=len(branches),
            missed_lines=sorted(n for n, c in counted.items() if c == 0)))
    files.sort(key=lambda f: f.name)
    return CoverageSummary(files)
