"""The self-contained HTML report: inline CSS, images as data URIs, no script, no network."""
from __future__ import annotations

import datetime
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

from ...protocol.behaviour import anchors_in, section_text
from .html_defects import defects_section
from .html_triage import (
    by_requirement_section,
    failure_groups_section,
    faults_section,
    legend_section,
    skips_section,
    summary_section,
)
from .junit import VERDICTS, Case, JunitRun
from .markup import LABEL as _LABEL
from .markup import SHORT as _SHORT
from .markup import esc as _e
from .markup import names
from .markup import tag as _tag
from .markup import tests_cell as _tests_cell
from .plots import Plot
from .requirement_coverage import Coverage
from .triage import Change, FailureGroup, headline, scrub

__all__ = ["render_html", "Triage"]


@dataclass
class Triage:
    """What the first screen needs beyond the runs: failure groups, the previous run's changes
    (per JUnit path: (previous run's name, changes), None when there is no previous run), the
    known deviations' explanations, the requirement statements."""

    groups: List[FailureGroup] = field(default_factory=list)
    changes: Dict[str, Optional[Tuple[str, List[Change]]]] = field(default_factory=dict)
    deviations: Dict[str, Tuple[str, str]] = field(default_factory=dict)   # key -> (explain, facts)
    statements: Dict[str, str] = field(default_factory=dict)

# Everything wraps: at 1400 px nothing may run off the page (long assertion lines, test lists,
# transcript excerpts); wide tables have fixed layouts so their columns share the width.
_CSS = """
*{box-sizing:border-box}
body{font:14px/1.35 system-ui,-apple-system,"Segoe UI",sans-serif;margin:0 auto;padding:10px 18px;
max-width:1400px;color:#222;overflow-wrap:break-word}
h1{font-size:1.45em;margin:.1em 0 .2em} h2{font-size:1.2em;border-bottom:2px solid #ddd;padding-bottom:.15em;
margin:1.2em 0 .4em} h3{font-size:1em}
header p{margin:.25em 0}
table{border-collapse:collapse;margin:.4em 0;max-width:100%} th,td{border:1px solid #ccc;padding:3px 6px;
text-align:left;vertical-align:top} th{background:#f2f2f2}
table.wide,table.groups,table.cov{width:100%;table-layout:fixed}
td.n{text-align:right;font-variant-numeric:tabular-nums}
.pass{background:#dff3df} .fail{background:#f9d0d0} .skip{background:#eeeeee}
.target_fault{background:#e8d5f5} .not_run{background:#e4e4e4}
.known_deviation{background:#fde9c4}
.informational{background:#dbe9f8} .hole{background:#ffb3b3;font-weight:bold} .untested{background:#f4f1c9}
.zero{color:#bbb;background:none} pre{background:#f7f7f7;border:1px solid #ddd;padding:.5em;font-size:12px;
white-space:pre-wrap;overflow-wrap:anywhere;margin:.3em 0}
.muted{color:#777} .warn{color:#a00} .tag{display:inline-block;padding:0 5px;border-radius:3px;font-size:12px}
figure{margin:1em 0;display:inline-block;width:49%;vertical-align:top} figcaption{font-size:12px;color:#555}
svg.chart{max-width:100%;height:auto;border:1px solid #ddd;background:#fff}
code{font-size:12px;white-space:pre-wrap;overflow-wrap:anywhere} td.tests,.tests{font-size:12px;color:#555}
td.byrun{font-size:12px}
.verdict{padding:1px 10px;border-radius:4px} .verdict.fail{background:#c62828;color:#fff}
.verdict.pass{background:#2e7d32;color:#fff} .verdict.target_fault{background:#6a1b9a;color:#fff}
.target{font-size:15px;margin:.1em 0}
.chip{display:inline-block;padding:2px 8px;margin:2px 4px 2px 0;border-radius:12px;border:1px solid #ccc;
color:#222;text-decoration:none} .chip b{font-size:15px}
.changes{background:#fffbe6;border:1px solid #eedc82;padding:4px 8px}
.exchange{font-size:12px} .exchange .lbl{display:inline-block;width:5.5em;color:#777}
.sent code{font-weight:bold;background:#eef3ff;padding:0 4px}
table.xr{width:100%;table-layout:fixed;margin:.2em 0}
table.xr td,table.xr th{font:12px monospace;padding:1px 4px;
white-space:pre-wrap;overflow-wrap:anywhere} table.xr th{font-family:inherit}
tr.first td,span.first,.legendmark{background:#ffcdd2;outline:2px solid #c62828}
tr.diff td{background:#fdeaea}
.why{font-size:12.5px;margin:.2em 0} .case{border-left:3px solid #f9d0d0;padding-left:8px;margin:.5em 0}
details>summary{cursor:pointer}
"""


def _runs_section(runs: Sequence[JunitRun]) -> str:
    rows = []
    for i, run in enumerate(runs, 1):
        counts = run.counts()
        cells = "".join(f'<td class="n {v if counts[v] else "zero"}">{counts[v]}</td>' for v in VERDICTS)
        problems = ("<br>".join(f'<span class="warn">{_e(p)}</span>' for p in run.problems)
                    or '<span class="muted">valid for common CI readers</span>')
        # What happened to the target (conformance/plugin/run.py): a reset, a stop, an interrupted run,
        # set-up commands it refused (conformance/setup_check.py).
        problems += "".join(f'<br><span class="warn">{key}: {_e(run.properties[key][0])}</span>'
                            for key in ("reset", "stopped", "partial", "setup_refused")
                            if run.properties.get(key))
        rows.append(f"<tr><td>{i}</td><td>{_e(run.target or '?')}</td><td>{_e(run.firmware or '?')}</td>"
                    f"<td>{_e(run.profile or '?')}</td><td class=n>{len(run.cases)}</td>{cells}"
                    f"<td><code>{_e(run.path)}</code><br>{problems}</td></tr>")
    head = "".join(f"<th>{_e(_SHORT[v])}</th>" for v in VERDICTS)
    cols = "<col style='width:2.5em'><col style='width:14%'><col style='width:13%'><col style='width:5em'>" \
        "<col style='width:4.5em'>" + "<col style='width:5em'>" * len(VERDICTS) + "<col>"
    return ("<h2 id=runs>Runs (per target and profile)</h2><table class=wide>"
            f"<colgroup>{cols}</colgroup>"
            "<tr><th>#</th><th>target</th>"
            f"<th>firmware</th><th>profile</th><th>cases</th>{head}<th>JUnit file</th></tr>"
            f"{''.join(rows)}</table>")


def _run_status(row, label: str) -> str:  # type: ignore[no-untyped-def]
    verdicts = {c.verdict for lab, c in row.cases if lab == label}
    for v in ("fail", "known_deviation", "pass"):
        if v in verdicts:
            return v
    return "untested" if verdicts else "hole"


def _coverage_section(cov: Coverage, runs: Sequence[JunitRun]) -> str:
    sc = cov.status_counts()
    total = len(cov.rows)
    covered = total - sc.get("hole", 0)
    summary = (f"<p>{covered} of {total} requirement IDs are cited by at least one test; "
               f"<b class=warn>{sc.get('hole', 0)} hole(s)</b>. "
               + ", ".join(f"{_tag(k)} {n}" for k, n in sorted(sc.items()))
               + ". Counts are cases; <code>obs</code> and the statuses are explained in the "
               "<a href='#legend'>legend</a>.</p>")
    head = "".join(f"<th>{_e(_SHORT[v])}</th>" for v in VERDICTS)
    multi = len(runs) > 1
    rows, area = [], None
    for row in cov.rows:
        r = row.requirement
        if r.area != area:
            area = r.area
            rows.append(f'<tr><th colspan="{5 + len(VERDICTS) + multi}">{_e(area)}</th></tr>')
        counts = row.counts
        cells = "".join(f'<td class="n {v if counts[v] else "zero"}">{counts[v]}</td>' for v in VERDICTS)
        tests = _tests_cell(row.cases)
        by_run = "<br>".join(f'<span class="tag {st}">{i + 1}: {_SHORT[st]}</span>'
                             for i, st in enumerate(_run_status(row, run.label) for run in runs)) \
            if multi and row.status != "hole" else ""
        rows.append(f'<tr><td class="{row.status}" id="req-{_e(r.id)}">{_e(r.id)}</td><td>{_e(r.obs)}</td>'
                    f'<td>{_e(r.statement)}</td>{cells}<td>{_tag(row.status)}</td>'
                    + (f'<td class="byrun">{by_run}</td>' if multi else "") +
                    f'<td class="tests">{names(tests)}</td></tr>')
    per_run = f"<th>by run (1..{len(runs)})</th>" if multi else ""
    cols = ("<col style='width:10.5em'><col style='width:4em'><col style='width:24%'>"
            + "<col style='width:4.6em'>" * len(VERDICTS) + "<col style='width:7.5em'>"
            + ("<col style='width:7em'>" if multi else "") + "<col>")
    table = (f"<table class=cov><colgroup>{cols}</colgroup>"
             f"<tr><th>ID</th><th>obs</th><th>statement</th>{head}"
             f"<th>status</th>{per_run}<th>tests</th></tr>{''.join(rows)}</table>")
    other = ""
    if cov.other_ids:
        items = "".join(f"<li><code>{_e(rid)}</code>: {len(cases)} case(s) — "
                        f"{_e(', '.join(sorted({c.verdict for _r, c in cases})))}</li>"
                        for rid, cases in cov.other_ids.items())
        other = ("<details><summary>IDs cited by tests that are not in REQUIREMENTS.md "
                 f"(firmware facts, or typos to fix): {len(cov.other_ids)}</summary>"
                 f"<ul>{items}</ul></details>")
    return f"<h2 id=coverage>Requirement coverage</h2>{summary}{table}{other}"


def _case_list(items: List[Tuple[JunitRun, Case]], excerpts: Dict[int, List[str]]) -> str:
    parts = []
    for run, case in items:
        reqs = ", ".join(case.requirements) or "no requirement ID"
        parts.append(f"<div class=case><p>{_tag(case.verdict)} <code>{_e(case.test_id)}</code> "
                     f"<span class=muted>{_e(run.label)} · {_e(reqs)}</span></p>")
        for key in ("deviations", "notes"):
            if case.prop(key):
                parts.append(f"<p class=why><b>{key}:</b> {_e(case.prop(key))}</p>")
        if case.detail:
            parts.append(f"<details><summary>details</summary><pre>{_e(scrub(case.detail))}</pre></details>")
        ex = excerpts.get(id(case))
        if ex:
            parts.append(f"<details><summary>transcript <code>{_e(case.transcript)}</code></summary>"
                         f"<pre>{_e(chr(10).join(ex))}</pre></details>")
        parts.append("</div>")
    return "".join(parts)


def _deviations_section(items: List[Tuple[JunitRun, Case]], excerpts: Dict[int, List[str]],
                        explained: Dict[str, Tuple[str, str]]) -> str:
    """Known deviations grouped by their key (the suite's ``deviations`` property), each
    explained in a sentence with its sections of docs/FIRMWARE-BEHAVIOUR.md; the cases one click away."""
    if not items:
        return "<h2 id=deviations>Known deviations</h2><p class=muted>No known deviations were reported.</p>"
    groups: Dict[str, List[Tuple[JunitRun, Case]]] = {}
    for run, case in items:
        keys = [k for k in case.prop("deviations").split(",") if k.strip()] or ["(not named)"]
        for key in keys:
            groups.setdefault(key.strip(), []).append((run, case))
    rows = []
    for key, members in sorted(groups.items()):
        explain, where = explained.get(key, ("(no explanation in deviations.json)", "?"))
        reqs = sorted({r for _run, c in members for r in c.requirements})
        tests = _tests_cell([(run.label, c) for run, c in members])
        rows.append(f"<tr><td><code>{_e(key)}</code></td><td>{_e(explain)}</td><td><code>{_e(where)}</code>"
                    f"{_quoted_sections(where)}</td>"
                    f'<td class="n">{len(members)}</td><td>{_e(", ".join(reqs))}</td>'
                    f'<td class="tests">{_e(tests)}<details><summary>the case(s)</summary>'
                    f"{_case_list(members, excerpts)}</details></td></tr>")
    return (f"<h2 id=deviations>Known deviations ({len(items)} case(s), {len(groups)} kind(s))</h2>"
            "<p class=muted>Where a release is known to differ from the 2021-10 document (the project's "
            "docs/FIRMWARE-BEHAVIOUR.md, section by anchor) and did exactly what that says: expected, not a "
            "finding.</p><table class=wide><colgroup>"
            "<col style='width:15em'><col style='width:30%'><col style='width:24%'><col style='width:4.5em'>"
            "<col style='width:9em'><col></colgroup><tr><th>deviation</th><th>what it means</th>"
            "<th>explained in</th><th>cases</th><th>requirements</th><th>tests</th></tr>"
            f"{''.join(rows)}</table>")


def _quoted_sections(where: str) -> str:
    """The cited sections of docs/FIRMWARE-BEHAVIOUR.md, quoted (the package carries the document),
    so the page explains a deviation without a file the reader may not have."""
    texts = [text for text in (section_text(a) for a in anchors_in(where)) if text]
    if not texts:
        return ""
    return f"<details><summary>what it says</summary><pre>{_e((chr(10) * 2).join(texts))}</pre></details>"


def _plots_section(plots: List[Plot]) -> str:
    parts = ["<h2 id=plots>Timing and controller plots</h2>"]
    if not plots:
        parts.append("<p class=muted>No transcript of these runs holds data lines, "
                     "<code>pulse/ramp done</code> lines or <code>debug 16</code> PID lines, "
                     "so there is nothing to plot.</p>")
        return "".join(parts)
    for p in plots:
        body = p.svg      # built by svg.py, every text in it escaped
        caption = "<br>".join(_e(s) for s in p.summary)
        parts.append(f"<figure>{body}<figcaption><b>{_e(p.title)}</b><br>{caption}</figcaption></figure>")
    return "".join(parts)


def _side_by_side(runs: Sequence[JunitRun]) -> str:
    order: List[str] = []
    grid: Dict[str, Dict[int, Case]] = {}
    for i, run in enumerate(runs):
        for case in run.cases:
            if case.test_id not in grid:
                order.append(case.test_id)
                grid[case.test_id] = {}
            grid[case.test_id][i] = case
    head = "".join(f"<th>{i + 1}. {_e(run.label)}</th>" for i, run in enumerate(runs))
    rows = []
    for tid in order:
        cells = []
        for i in range(len(runs)):
            c = grid[tid].get(i)
            if c is None:
                cells.append('<td class="muted">—</td>')
                continue
            why = headline(c) if c.verdict not in ("pass",) else ""
            cells.append(f'<td class="{c.verdict}">{_e(_LABEL[c.verdict])}'
                         + (f'<div class=why>{_e(why)}</div>' if why and why != "(no message)" else "")
                         + "</td>")
        rows.append(f"<tr><td><code>{_e(tid)}</code></td>{''.join(cells)}</tr>")
    return (f"<h2 id=cases>All cases, run by run</h2><details{' open' if len(runs) > 1 else ''}>"
            f"<summary>{len(order)} test(s)</summary><table class=wide><tr><th>test</th>{head}</tr>"
            f"{''.join(rows)}</table></details>")


def render_html(runs: Sequence[JunitRun], cov: Coverage, excerpts: Dict[int, List[str]], plots: List[Plot],
                tool_version: str, triage: Optional[Triage] = None) -> str:
    from .html_baseline import baseline_section
    from .triage import group_failures

    triage = triage or Triage()
    failures = [(r, c) for r in runs for c in r.cases if c.verdict == "fail"]
    groups = triage.groups or group_failures(failures)
    faults = [(r, c) for r in runs for c in r.cases if c.verdict in ("target_fault", "not_run")]
    skips = [(r, c) for r in runs for c in r.cases if c.verdict == "skip"]
    deviations = [(r, c) for r in runs for c in r.cases if c.verdict == "known_deviation"]
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    nav = " · ".join(f'<a href="#{a}">{t}</a>' for a, t in (
        ("failures", "failures"), ("by-requirement", "by requirement"), ("faults", "target faults"),
        ("skips", "skips"), ("deviations", "known deviations"), ("plots", "plots"), ("runs", "runs"),
        ("coverage", "coverage"), ("cases", "all cases"), ("legend", "legend")))
    body = "".join([
        summary_section(runs, triage.changes, f"built {now} by buildhat-conformance {tool_version}"),
        defects_section(runs),          # a firmware in the loop's own defects (sanitizers, crashes)
        baseline_section(runs),
        failure_groups_section(groups),
        faults_section(faults),
        skips_section(skips),
        f"<p class=muted>{nav}</p>",
        by_requirement_section(groups, triage.statements, excerpts),
        _deviations_section(deviations, excerpts, triage.deviations),
        _plots_section(plots),
        _runs_section(runs),
        _coverage_section(cov, runs),
        _side_by_side(runs),
        legend_section(),
    ])
    return ("<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8>"
            "<meta name=viewport content='width=device-width'>"
            "<title>Build HAT conformance report</title>"
            f"<style>{_CSS}</style></head><body>{body}</body></html>\n")
