"""Small HTML pieces both halves of the report use: escaping, verdict tags and their words."""
from __future__ import annotations

import html
from typing import Dict, List, Tuple

from .junit import Case

__all__ = ["esc", "names", "tag", "LABEL", "SHORT", "LETTER", "MEANING", "tests_cell"]

LABEL = {"pass": "pass", "fail": "fail", "target_fault": "target fault", "not_run": "not run",
         "skip": "skip", "known_deviation": "known deviation", "informational": "informational",
         "hole": "HOLE (no test)", "untested": "not exercised"}

SHORT = {"pass": "pass", "fail": "FAIL", "target_fault": "T fault", "not_run": "not run", "skip": "skip",
         "known_deviation": "known dev.", "informational": "info", "hole": "no test", "untested": "not run"}

#: The terminal's progress letters (conformance/plugin/progress.py's legend).
LETTER = {"pass": ".", "fail": "F", "target_fault": "T", "not_run": "N", "skip": "s",
          "known_deviation": "K", "informational": "I"}

MEANING = {
    "pass": "the target did what the 2021-10 document (or, where it is silent, docs/FIRMWARE-BEHAVIOUR.md) "
            "says",
    "fail": "the target answered, and the answer breaks the protocol: a finding against the target",
    "target_fault": "the target went silent, died, rebooted or garbled its output during the case: a fault "
                    "of the target or the link, not a verdict on the protocol",
    "not_run": "the case could not run (the target was gone before it started)",
    "skip": "the case needs something this target cannot do (a device plugged in, control of the "
            "supply...); the reason says what to connect",
    "known_deviation": "the target did exactly what docs/FIRMWARE-BEHAVIOUR.md says this release does "
                       "instead of the document: expected, not a regression",
    "informational": "a measurement the document does not bound (timing, rates); shown, never judged",
    "hole": "no test cites this requirement ID: a hole in the suite",
    "untested": "tests cite it, but none of them passed or failed here (all skipped or informational)",
}


def esc(x: object) -> str:
    return html.escape(str(x), quote=True)


def names(text: str) -> str:
    """Escaped test names that may wrap after an underscore (not in the middle of a word)."""
    return esc(text).replace("_", "_<wbr>")


def tag(verdict: str) -> str:
    return f'<span class="tag {esc(verdict)}">{esc(LABEL.get(verdict, verdict))}</span>'


def tests_cell(cases: List[Tuple[str, Case]]) -> str:
    """Test names, parametrizations folded: ``test_x ×12``."""
    counts: Dict[str, int] = {}
    for _run, c in cases:
        base = c.name.split("[", 1)[0]
        counts[base] = counts.get(base, 0) + 1
    return ", ".join(f"{n} ×{k}" if k > 1 else n for n, k in sorted(counts.items()))
