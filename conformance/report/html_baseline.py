"""The report's first screen, for a run made with ``--baseline``: the cases whose HAT output differs
from the baseline's, each with both sides' first differing line (conformance/comparison.py wrote
them into the JUnit file as properties)."""
from __future__ import annotations

from typing import Sequence

from .junit import JunitRun
from .markup import esc

__all__ = ["baseline_section"]


def baseline_section(runs: Sequence[JunitRun]) -> str:
    parts = []
    for run in runs:
        baseline = (run.properties.get("baseline") or [""])[0]
        if not baseline:
            continue
        listed = [c for c in run.cases if c.prop("baseline.difference")]
        timing = (run.properties.get("baseline.timing_sensitive") or ["0"])[0]
        note = (f" {esc(timing)} case(s) differ by timing only (asynchronous lines, or answers the "
                "baseline's own runs do not agree on either): not listed." if timing not in ("", "0") else "")
        if not listed:
            parts.append(f"<p class=changes>Compared with the baseline <code>{esc(baseline)}</code>: no "
                         f"case's HAT output differs.{note}</p>")
            continue
        intended = "intended", "<b class=warn>changed</b>"
        rows = "".join(
            f"<tr><td>{intended[0] if c.prop('baseline.difference') == 'intended' else intended[1]}</td>"
            f"<td><code>{esc(c.test_id)}</code></td><td><code>{esc(c.prop('baseline.target_line'))}</code>"
            f"</td><td><code>{esc(c.prop('baseline.baseline_line'))}</code></td></tr>" for c in listed)
        parts.append(f"<section id=baseline><p class=changes>Compared with the baseline <code>{esc(baseline)}"
                     f"</code>: {len(listed)} case(s) whose HAT output differs.{note}</p>"
                     "<table class=wide><tr><th></th><th>case</th><th>this target's first differing line</th>"
                     f"<th>the baseline's</th></tr>{rows}</table></section>")
    return "".join(parts)
