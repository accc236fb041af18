"""How the project cites its reference of firmware behaviour, ``docs/FIRMWARE-BEHAVIOUR.md``.

Users have the project, not the facts it was written from, so every text a user reads (report,
JUnit messages, deviations.json) names a section of that document by its stable ``fb-`` anchor.
tests/test_behaviour_doc.py checks that every anchor cited anywhere exists in the document.
"""
from __future__ import annotations

import re
from typing import Iterable, Tuple

__all__ = ["DOC", "ANCHOR", "cite", "anchors_in"]

#: Where the document lives in the repository (and the source distribution).
DOC = "docs/FIRMWARE-BEHAVIOUR.md"
#: An anchor as the document declares it (``<a id="fb-…"></a>``) and as the project cites it.
ANCHOR = re.compile(r"(?<![\w-])fb-[a-z0-9]+(?:-[a-z0-9]+)*")


def cite(anchors: Iterable[str]) -> str:
    """``docs/FIRMWARE-BEHAVIOUR.md#fb-on-off, #fb-doc-on-off``: one reference a reader can follow."""
    names = list(anchors)
    if not names:
        return DOC
    return f"{DOC}#{names[0]}" + "".join(f", #{a}" for a in names[1:])


def anchors_in(text: str) -> Tuple[str, ...]:
    """Every ``fb-`` anchor cited in ``text``, in order of appearance."""
    return tuple(m.group(0) for m in ANCHOR.finditer(text))
