"""How the project cites its reference of firmware behaviour, ``docs/FIRMWARE-BEHAVIOUR.md``.

Users have the project, not the facts it was written from, so every text a user reads (report,
JUnit messages, deviations.json) names a section of that document by its stable ``fb-`` anchor.
The package carries the document (``protocol/FIRMWARE-BEHAVIOUR.md`` is a link to it, installed as
a copy), so the report can quote the sections it cites even where no ``docs/`` folder was installed.
tests/protocol/test_behaviour.py checks that every anchor cited anywhere exists in the document.
"""
from __future__ import annotations

import re
from functools import lru_cache
from importlib import resources
from typing import Iterable, Tuple

__all__ = ["DOC", "ANCHOR", "cite", "anchors_in", "section_text"]

#: Where the document lives in the repository (and the source distribution).
DOC = "docs/FIRMWARE-BEHAVIOUR.md"
#: An anchor as the document declares it (``<a id="fb-…"></a>``) and as the project cites it.
ANCHOR = re.compile(r"(?<![\w-])fb-[a-z0-9]+(?:-[a-z0-9]+)*")
_DECLARED = re.compile(r'<a id="(fb-[a-z0-9-]+)"></a>')
_ITEM = re.compile(r"(?:[-*] |\d+\. |#)")      # a list item or a heading starts the next part


def cite(anchors: Iterable[str]) -> str:
    """``docs/FIRMWARE-BEHAVIOUR.md#fb-on-off, #fb-doc-on-off``: one reference a reader can follow."""
    names = list(anchors)
    if not names:
        return DOC
    return f"{DOC}#{names[0]}" + "".join(f", #{a}" for a in names[1:])


def anchors_in(text: str) -> Tuple[str, ...]:
    """Every ``fb-`` anchor cited in ``text``, in order of appearance."""
    return tuple(m.group(0) for m in ANCHOR.finditer(text))


@lru_cache(maxsize=1)
def _document() -> str:
    here = resources.files(__name__.rpartition(".")[0])
    return here.joinpath("FIRMWARE-BEHAVIOUR.md").read_text(encoding="utf-8")


def section_text(anchor: str) -> str:
    """The text of one section as Markdown without anchor tags ("" if ``anchor`` is not declared).

    An anchor on a line of its own opens a section that runs to the next such anchor; one inside a
    list item (``- <a id=...>``) covers that item, its continuation and anything nested under it."""
    lines = _document().split("\n")
    tag = f'<a id="{anchor}"></a>'
    at = next((i for i, line in enumerate(lines) if tag in line), None)
    if at is None:
        return ""
    if lines[at].strip() == tag:
        end = next((j for j in range(at + 1, len(lines)) if _DECLARED.fullmatch(lines[j].strip())),
                   len(lines))
    else:
        indent = len(lines[at]) - len(lines[at].lstrip())
        end = at + 1
        while end < len(lines) and lines[end].strip() and not (
                len(lines[end]) - len(lines[end].lstrip()) <= indent and _ITEM.match(lines[end].lstrip())):
            end += 1
    body = _DECLARED.sub("", "\n".join(lines[at:end])).strip()
    return body.rstrip("-").strip()       # a section that ends at a rule does not quote the rule
