"""The requirement IDs (protocol/requirements.py): read from the project's copy of REQUIREMENTS.md, the
same rows as the developers' original, and every ID a conformance case cites is one of them."""
from __future__ import annotations

import re

from repo_paths import REPO
from shared_material import need_shared

from buildhat_conformance.protocol.requirements import requirement_ids, requirements

CITED = re.compile(r"\breq\(([^)]*)\)")


def _rows(text: str) -> list:
    """``(id, obs)`` of every table row, split by hand (not by the module's pattern)."""
    rows = []
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        is_row = line.startswith("| ") and len(cells) >= 3
        if is_row and cells[0] not in ("ID", "") and set(cells[0]) != {"-"}:
            rows.append((cells[0], cells[-1]))
    return rows


def test_every_row_of_the_original_is_a_requirement():
    original = need_shared("protocol", "REQUIREMENTS.md", what="the original of protocol/REQUIREMENTS.md")
    assert [(r.id, r.obs) for r in requirements()] == _rows(original.read_text(encoding="utf-8"))


def test_ids_are_unique_and_each_has_a_statement_and_an_area():
    ids = requirement_ids()
    assert len(ids) == len(set(ids)) > 50
    assert all(r.statement and r.area and r.obs in ("wire", "debug", "device", "rig") for r in requirements())


def test_every_requirement_a_conformance_case_cites_exists():
    known = set(requirement_ids())
    cited = set()
    for path in (REPO / "conformance").rglob("test_*.py"):
        for args in CITED.findall(path.read_text(encoding="utf-8")):
            cited |= set(re.findall(r"[\"']([A-Z][A-Z0-9-]+)[\"']", args))
    unknown = sorted(i for i in cited if not i.startswith("FW-") and i not in known)   # FW-: firmware facts
    assert cited and not unknown, unknown
