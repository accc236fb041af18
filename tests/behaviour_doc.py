"""Exact data carried by docs/FIRMWARE-BEHAVIOUR.md (help texts, the shortest-prefix table), read
by anchor, so tests need no ``../shared``: the document is the project's own account of the facts,
and tests/protocol/test_behaviour.py checks its exact strings against the original where that exists."""
from __future__ import annotations

import re
from typing import Dict, List

from shared_material import BEHAVIOUR_DOC

_ANCHOR = re.compile(r'<a id="(fb-[a-z0-9-]+)"></a>')


def text() -> str:
    return BEHAVIOUR_DOC.read_text(encoding="utf-8")


def anchors(doc: str) -> List[str]:
    """Every anchor the document declares, in order."""
    return _ANCHOR.findall(doc)


def section(doc: str, anchor: str) -> str:
    """From ``anchor`` to the next anchor the document declares (inline ones included)."""
    start = doc.index(f'<a id="{anchor}"></a>')
    nxt = _ANCHOR.search(doc, start + len(anchor) + 13)
    return doc[start:nxt.start() if nxt else len(doc)]


def code_block(doc: str, anchor: str) -> List[str]:
    """The lines of the first fenced block of ``anchor``'s section."""
    return section(doc, anchor).split("```", 2)[1].strip("\n").split("\n")


def help_lines(doc: str) -> Dict[str, List[str]]:
    """The help text of each generation as lines: "R6-R7", "R1-R4" and "R5" (R1-R4 plus the
    two lines the R5 paragraph names, inserted where it says)."""
    new, old = code_block(doc, "fb-help-r6"), code_block(doc, "fb-help-r1")
    extra = re.findall(r"`(  (?:selrate )?<selrate>[^`]*)`", section(doc, "fb-help-r5"))
    assert len(extra) == 2, extra
    r5 = list(old)
    r5.insert(next(i for i, x in enumerate(r5) if x.startswith("  selonce <selmode> ")) + 1, extra[0])
    r5.insert(max(i for i, x in enumerate(r5) if x.strip() == "f4=float") + 1, extra[1])
    return {"R6-R7": new, "R1-R4": old, "R5": r5}


def shortest_table(doc: str) -> Dict[str, List[str]]:
    """The rows of the shortest-prefix table: command -> its cells for R1-R4, R5, R6-R7."""
    rows = {}
    for line in section(doc, "fb-shortest-prefix").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or cells[0] in ("Command", "") or set(cells[0]) <= set("-"):
            continue
        rows[cells[0]] = cells[1:]
    return rows
