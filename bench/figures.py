"""A benchmark figure: a median of several runs, printed next to its goal.

Figures never pass or fail a build: the machines are shared and noisy. They say whether the
goal was met on this run, and the table and ``reports/bench.json`` keep every sample.
"""
from __future__ import annotations

import json
import os
import statistics
from dataclasses import asdict, dataclass, field
from typing import List, Optional


@dataclass
class Figure:
    name: str
    unit: str
    goal: str = "-"                # human text, e.g. "<= 20 s"
    better: str = "lower"          # "lower" or "higher": how the goal reads
    target: Optional[float] = None  # the goal as a number, for the met/not met column
    samples: List[float] = field(default_factory=list)
    note: str = ""

    @property
    def value(self) -> Optional[float]:
        return statistics.median(self.samples) if self.samples else None

    @property
    def met(self) -> Optional[bool]:
        if self.value is None or self.target is None:
            return None
        return self.value <= self.target if self.better == "lower" else self.value >= self.target

    def as_dict(self) -> dict:
        d = asdict(self)
        d.update(value=self.value, met=self.met)
        return d


def _fmt(v: Optional[float]) -> str:
    if v is None:
        return "-"
    if abs(v) >= 1000:
        return f"{v:,.0f}"
    return f"{v:.3g}"


def render_table(figures: List[Figure]) -> str:
    rows = [("figure", "median", "unit", "goal", "met", "runs", "note")]
    for f in figures:
        met = {True: "yes", False: "NO", None: "-"}[f.met]
        rows.append((f.name, _fmt(f.value), f.unit, f.goal, met, str(len(f.samples)), f.note))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def write_json(figures: List[Figure], path: str, meta: dict) -> None:
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w", encoding="utf-8") as fh:
        json.dump({"meta": meta, "figures": [f.as_dict() for f in figures]}, fh, indent=1)
