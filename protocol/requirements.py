"""The requirement IDs of the protocol document (REQUIREMENTS.md, a copy of the developers' original)."""
from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import List

__all__ = ["Requirement", "requirements", "requirement_ids"]


@dataclass(frozen=True)
class Requirement:
    id: str
    statement: str
    obs: str       # wire / debug / device / rig
    area: str      # the section heading, e.g. "Command syntax"


@lru_cache(maxsize=1)
def requirements() -> List[Requirement]:
    data = resources.files(__name__.rpartition(".")[0]).joinpath("REQUIREMENTS.md")   # in this package
    text = data.read_text(encoding="utf-8")
    out, area = [], ""
    for line in text.splitlines():
        if line.startswith("## "):
            area = line[3:].split("—")[0].strip()
            continue
        m = re.match(r"^\| ([A-Z][A-Z0-9-]+) \| (.*) \| (\w+) \|$", line)
        if m and m.group(1) != "ID":
            out.append(Requirement(m.group(1), m.group(2).strip(), m.group(3), area))
    return out


def requirement_ids() -> List[str]:
    return [r.id for r in requirements()]
