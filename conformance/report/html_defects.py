"""The report's first-screen section "firmware defects found by the sanitizers": each distinct
report a firmware in the loop gave (kind, file, line), with the cases that met it; suppressed
ones apart (conformance/plugin/firmware_findings.py writes them as the JUnit property
``firmware_defects``)."""
from __future__ import annotations

import json
from typing import Any, List, Sequence

from .junit import JunitRun
from .markup import esc

__all__ = ["defects_section", "PROPERTY"]

PROPERTY = "firmware_defects"
CASES_SHOWN = 5


def _defects(run: JunitRun) -> List[dict]:
    values = run.properties.get(PROPERTY) or []
    try:
        rows: Any = json.loads(values[-1]) if values else []
    except ValueError:
        return []
    return [r for r in rows if isinstance(r, dict)] if isinstance(rows, list) else []


def defects_section(runs: Sequence[JunitRun]) -> str:
    """Nothing when no run lists a firmware defect."""
    items = []
    for run in runs:
        for d in _defects(run):
            where = f"{d.get('file')}:{d.get('line')}" if d.get("file") else "(no source line)"
            cases = [str(c) for c in d.get("cases") or []]
            shown = ", ".join(f"<code>{esc(c)}</code>" for c in cases[:CASES_SHOWN]) + (
                f" and {len(cases) - CASES_SHOWN} more" if len(cases) > CASES_SHOWN else "")
            tag = (f'<span class=muted>suppressed by <code>{esc(str(d["suppressed_by"]))}</code></span>'
                   if d.get("suppressed_by") else '<span class="warn">failed</span>')
            items.append(f"<li><b>{esc(str(d.get('kind', '?')))}</b> at <code>{esc(where)}</code> · {tag}"
                         f"<br>{esc(str(d.get('first', '')))}"
                         f"<br><span class=muted>met by</span> {shown}</li>")
    if not items:
        return ""
    return (f"<h2 id=firmware-defects>Firmware defects found by the sanitizers ({len(items)})</h2>"
            f"<ul>{''.join(items)}</ul>")
