"""The page and the JSON a `sil mutate` campaign leaves: per mutant its change, what happened,
which cases killed it or saw a difference, and the requirement IDs nearest to a survivor.
One self-contained HTML file (no script, no network), like the run report."""
from __future__ import annotations

import html
import json
from pathlib import Path

from .mutation import STATUSES, Campaign

__all__ = ["write_reports"]

_CSS = """body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;color:#222}
table{border-collapse:collapse;width:100%}td,th{border-bottom:1px solid #ddd;padding:4px 6px;text-align:left;
vertical-align:top}code{font:12px ui-monospace,monospace}.killed{color:#1a7f37}.survived{color:#b42318;
font-weight:600}.killed-by-fault{color:#b54708}.likely-equivalent,.no-build,.no-boot{color:#667085}"""


def write_reports(campaign: Campaign, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "mutation.json").write_text(json.dumps(campaign.as_dict(), indent=1), encoding="utf-8")
    order = {s: i for i, s in enumerate(("survived", "killed-by-fault", "killed", "likely-equivalent",
                                         "no-boot", "no-build"))}
    rows = []
    for o in sorted(campaign.outcomes, key=lambda o: (order.get(o.status, 9), o.mutant.file, o.mutant.line)):
        m = o.mutant
        change = f"<code>{html.escape(m.original)}</code> &rarr; <code>{html.escape(m.replacement)}</code>"
        who = (html.escape(o.verdict_text()) if o.status == "killed"
               else "<br>".join(html.escape(c) for c in o.cases[:6]) or html.escape(o.detail))
        rows.append(f"<tr><td class='{o.status}'>{o.status}</td><td>{html.escape(m.file)}:{m.line}"
                    f"<br><small>{html.escape(m.function)}</small></td><td>{m.kind}</td><td>{change}</td>"
                    f"<td>{who}</td><td>{html.escape(', '.join(o.requirements))}</td></tr>")
    counts = " &middot; ".join(f"{campaign.count(s)} {s}" for s in STATUSES)
    page = (f"<!doctype html><meta charset='utf-8'><title>Mutation campaign</title><style>{_CSS}</style>"
            f"<h1>Mutation score {campaign.score_text()}</h1><p>{html.escape(campaign.tree)}: "
            f"{campaign.count('killed')} of {campaign.judged} mutants that are not likely equivalent were "
            f"killed by a failing case. {counts}. {campaign.seconds:.0f} s.</p>"
            "<p>A <b>survivor</b> changed what the HAT sent in the cases listed, yet every case passed: "
            "the suite does not defend that line. <b>Likely equivalent</b>: no byte the HAT sent in the "
            "whole suite differs from the unmutated firmware's."
            + (" A killed mutant's run stopped at its first failing case (<code>--all-cases</code> runs "
               "them all)." if campaign.stop_at_first else "") + "</p>"
            "<table><tr><th>outcome</th><th>where</th><th>kind</th><th>change</th>"
            "<th>killed by / saw a difference</th><th>requirements</th></tr>" + "".join(rows) + "</table>")
    path = folder / "mutation.html"
    path.write_text(page, encoding="utf-8")
    return path
