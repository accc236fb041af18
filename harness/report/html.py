"""The self-contained HTML report: inline CSS, images as data URIs, no script, no network."""
from __future__ import annotations

import base64
import datetime
import html
from typing import Dict, List, Sequence, Tuple

from ..extras import install_hint
from .coverage import Coverage
from .junit import VERDICTS, Case, Run
from .plots import Plot

__all__ = ["render_html"]

_LABEL = {"pass": "pass", "fail": "fail", "skip": "skip", "known_deviation": "known deviation",
          "informational": "informational", "hole": "HOLE (no test)", "untested": "not exercised"}

_CSS = """
body{font:14px/1.4 system-ui,-apple-system,"Segoe UI",sans-serif;margin:1.5em auto;max-width:1200px;
color:#222}
h1{font-size:1.6em;margin-bottom:.2em} h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0} th,td{border:1px solid #ccc;padding:3px 7px;text-align:left;
vertical-align:top} th{background:#f2f2f2} td.n{text-align:right;font-variant-numeric:tabular-nums}
.pass{background:#dff3df} .fail{background:#f9d0d0} .skip{background:#eeeeee}
.known_deviation{background:#fde9c4}
.informational{background:#dbe9f8} .hole{background:#ffb3b3;font-weight:bold} .untested{background:#f4f1c9}
.zero{color:#bbb} pre{background:#f7f7f7;border:1px solid #ddd;padding:.6em;overflow-x:auto;font-size:12px}
.muted{color:#777} .warn{color:#a00} .tag{display:inline-block;padding:0 5px;border-radius:3px;font-size:12px}
figure{margin:1em 0} figcaption{font-size:12px;color:#555} img{max-width:100%;border:1px solid #ddd}
code{font-size:12px} td.stmt{min-width:22em} td.tests{font-size:12px;max-width:26em}
td.byrun{white-space:nowrap;font-size:12px}
"""


_SHORT = {"pass": "pass", "fail": "FAIL", "skip": "skip", "known_deviation": "deviation",
          "informational": "info", "hole": "no test", "untested": "not run"}


def _e(x: object) -> str:
    return html.escape(str(x), quote=True)


def _tag(verdict: str) -> str:
    return f'<span class="tag {_e(verdict)}">{_e(_LABEL.get(verdict, verdict))}</span>'


def _runs_section(runs: Sequence[Run]) -> str:
    rows = []
    for i, run in enumerate(runs, 1):
        counts = run.counts()
        cells = "".join(f'<td class="n {v if counts[v] else "zero"}">{counts[v]}</td>' for v in VERDICTS)
        problems = ("<br>".join(f'<span class="warn">{_e(p)}</span>' for p in run.problems)
                    or '<span class="muted">valid for common CI readers</span>')
        rows.append(f"<tr><td>{i}</td><td>{_e(run.target or '?')}</td><td>{_e(run.firmware or '?')}</td>"
                    f"<td>{_e(run.profile or '?')}</td><td>{len(run.cases)}</td>{cells}"
                    f"<td><code>{_e(run.path)}</code><br>{problems}</td></tr>")
    head = "".join(f"<th>{_e(_LABEL[v])}</th>" for v in VERDICTS)
    return ("<h2 id=runs>Runs (per target and profile)</h2><table><tr><th>#</th><th>target</th>"
            f"<th>firmware</th><th>profile</th><th>cases</th>{head}<th>JUnit file</th></tr>"
            f"{''.join(rows)}</table>")


def _run_status(row, label: str) -> str:  # type: ignore[no-untyped-def]
    verdicts = {c.verdict for lab, c in row.cases if lab == label}
    for v in ("fail", "known_deviation", "pass"):
        if v in verdicts:
            return v
    return "untested" if verdicts else "hole"


def _coverage_section(cov: Coverage, runs: Sequence[Run]) -> str:
    sc = cov.status_counts()
    total = len(cov.rows)
    covered = total - sc.get("hole", 0)
    summary = (f"<p>{covered} of {total} requirement IDs are cited by at least one test; "
               f"<b class=warn>{sc.get('hole', 0)} hole(s)</b>. "
               + ", ".join(f"{_tag(k)} {n}" for k, n in sorted(sc.items())) + "</p>")
    head = "".join(f"<th>{_e(_LABEL[v])}</th>" for v in VERDICTS)
    rows, area = [], None
    for row in cov.rows:
        r = row.requirement
        if r.area != area:
            area = r.area
            rows.append(f'<tr><th colspan="{5 + len(VERDICTS) + (len(runs) > 1)}">{_e(area)}</th></tr>')
        counts = row.counts
        cells = "".join(f'<td class="n {v if counts[v] else "zero"}">{counts[v]}</td>' for v in VERDICTS)
        tests = _tests_cell(row.cases)
        by_run = "<br>".join(f'<span class="tag {st}">{i + 1}: {_SHORT[st]}</span>'
                             for i, st in enumerate(_run_status(row, run.label) for run in runs)) \
            if len(runs) > 1 and row.status != "hole" else ""
        rows.append(f'<tr><td class="{row.status}" id="req-{_e(r.id)}">{_e(r.id)}</td><td>{_e(r.obs)}</td>'
                    f'<td class="stmt">{_e(r.statement)}</td>{cells}<td>{_tag(row.status)}</td>'
                    + (f'<td class="byrun">{by_run}</td>' if len(runs) > 1 else "") +
                    f'<td class="muted tests">{_e(tests)}</td></tr>')
    per_run = f"<th>by run (1..{len(runs)})</th>" if len(runs) > 1 else ""
    table = (f"<table><tr><th>ID</th><th>obs</th><th>statement</th>{head}<th>status</th>{per_run}"
             "<th>tests</th></tr>"
             f"{''.join(rows)}</table>")
    other = ""
    if cov.other_ids:
        items = "".join(f"<li><code>{_e(rid)}</code>: {len(cases)} case(s) — "
                        f"{_e(', '.join(sorted({c.verdict for _r, c in cases})))}</li>"
                        for rid, cases in cov.other_ids.items())
        other = ("<p>IDs cited by tests that are not in REQUIREMENTS.md "
                 "(firmware facts, or typos to fix):</p>"
                 f"<ul>{items}</ul>")
    return f"<h2 id=coverage>Requirement coverage</h2>{summary}{table}{other}"


def _case_list(title: str, anchor: str, items: List[Tuple[Run, Case]], excerpts: Dict[int, List[str]],
               empty: str, heading: bool = True) -> str:
    if not items:
        return f"<h2 id={anchor}>{_e(title)}</h2><p class=muted>{_e(empty)}</p>"
    parts = [f"<h2 id={anchor}>{_e(title)} ({len(items)})</h2>"] if heading else []
    for run, case in items:
        reqs = ", ".join(case.requirements) or "no requirement ID"
        parts.append(f"<h3>{_tag(case.verdict)} <code>{_e(case.test_id)}</code></h3>"
                     f"<p class=muted>{_e(run.label)} · {_e(reqs)}</p>")
        summary = _failure_summary(case)
        if summary:
            parts.append(f"<pre>{_e(summary)}</pre>")
        for key in ("deviations", "notes"):
            if case.prop(key):
                parts.append(f"<p><b>{key}:</b> {_e(case.prop(key))}</p>")
        if case.detail:
            parts.append(f"<details><summary>details</summary><pre>{_e(case.detail)}</pre></details>")
        ex = excerpts.get(id(case))
        if ex:
            # Failures show their transcript; for deviations (expected) it is one click away.
            opened = " open" if case.verdict == "fail" else ""
            parts.append(f"<details{opened}><summary>transcript <code>{_e(case.transcript)}</code></summary>"
                         f"<pre>{_e(chr(10).join(ex))}</pre></details>")
        elif case.transcript:
            parts.append(f"<p class=warn>transcript {_e(case.transcript)} could not be read</p>")
    return "".join(parts)


def _deviations_section(items: List[Tuple[Run, Case]], excerpts: Dict[int, List[str]]) -> str:
    """Known deviations grouped by their key (the suite's ``deviations`` property): which
    releases show each, in how many cases, for which requirements; the cases one click away."""
    if not items:
        return "<h2 id=deviations>Known deviations</h2><p class=muted>No known deviations were reported.</p>"
    groups: Dict[str, List[Tuple[Run, Case]]] = {}
    for run, case in items:
        keys = [k for k in case.prop("deviations").split(",") if k.strip()] or ["(not named)"]
        for key in keys:
            groups.setdefault(key.strip(), []).append((run, case))
    rows = []
    for key, members in sorted(groups.items()):
        runs = sorted({run.label for run, _c in members})
        reqs = sorted({r for _run, c in members for r in c.requirements})
        tests = _tests_cell([(run.label, c) for run, c in members])
        detail = _case_list("", "", members, excerpts, "", heading=False)
        rows.append(f"<tr><td><code>{_e(key)}</code></td><td>{_e(', '.join(runs))}</td>"
                    f'<td class="n">{len(members)}</td><td>{_e(", ".join(reqs))}</td>'
                    f'<td class="muted tests">{_e(tests)}</td></tr>'
                    f'<tr><td colspan="5"><details><summary>the {len(members)} case(s)</summary>{detail}'
                    "</details></td></tr>")
    return (f"<h2 id=deviations>Known deviations ({len(items)} case(s), {len(groups)} kind(s))</h2>"
            "<p class=muted>Where a release is known (FIRMWARE-FACTS) to differ from the 2021-10 document "
            "and did exactly what the facts say.</p><table><tr><th>deviation</th><th>runs</th><th>cases</th>"
            f"<th>requirements</th><th>tests</th></tr>{''.join(rows)}</table>")


def _failure_summary(case: Case) -> str:
    """What went wrong in a few lines: pytest's ``E`` lines when the message is only the first
    line of a traceback (often the test's first source line), else the message."""
    e_lines = [ln[1:].strip() for ln in case.detail.splitlines() if ln.startswith("E ")]
    if e_lines:
        return "\n".join(e_lines[:8]) + ("\n…" if len(e_lines) > 8 else "")
    return case.message


def _tests_cell(cases: List[Tuple[str, Case]]) -> str:
    """Test names, parametrizations folded: ``test_x ×12``."""
    counts: Dict[str, int] = {}
    for _run, c in cases:
        base = c.name.split("[", 1)[0]
        counts[base] = counts.get(base, 0) + 1
    return ", ".join(f"{n} ×{k}" if k > 1 else n for n, k in sorted(counts.items()))


def _plots_section(plots: List[Plot], have_png: bool) -> str:
    parts = ["<h2 id=plots>Plots</h2>"]
    if not plots:
        parts.append("<p class=muted>No transcript of these runs holds <code>debug 16</code> PID lines, "
                     "so there is nothing to plot.</p>")
        return "".join(parts)
    if not have_png:
        parts.append("<p class=warn>matplotlib is not installed (the <code>plots</code> extra: "
                     f"<code>{_e(install_hint('plots'))}</code>); the numbers follow as text.</p>")
    for p in plots:
        body = ""
        if p.png:
            data = base64.b64encode(p.png).decode("ascii")
            body = f'<img alt="{_e(p.title)}" src="data:image/png;base64,{data}">'
        caption = "<br>".join(_e(s) for s in p.summary)
        parts.append(f"<figure>{body}<figcaption><b>{_e(p.title)}</b><br>{caption}</figcaption></figure>")
    return "".join(parts)


def _side_by_side(runs: Sequence[Run]) -> str:
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
            cells.append(f'<td class="{c.verdict}" title="{_e(c.message)}">{_e(_LABEL[c.verdict])}</td>'
                         if c else '<td class="muted">—</td>')
        rows.append(f"<tr><td><code>{_e(tid)}</code></td>{''.join(cells)}</tr>")
    return (f"<h2 id=cases>All cases, run by run</h2><details{' open' if len(runs) > 1 else ''}>"
            f"<summary>{len(order)} test(s)</summary><table><tr><th>test</th>{head}</tr>{''.join(rows)}"
            "</table></details>")


def render_html(runs: Sequence[Run], cov: Coverage, excerpts: Dict[int, List[str]], plots: List[Plot],
                have_png: bool, tool_version: str) -> str:
    failures = [(r, c) for r in runs for c in r.cases if c.verdict == "fail"]
    deviations = [(r, c) for r in runs for c in r.cases if c.verdict == "known_deviation"]
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    nav = " · ".join(f'<a href="#{a}">{t}</a>' for a, t in (
        ("runs", "runs"), ("coverage", "coverage"), ("failures", "failures"),
        ("deviations", "known deviations"), ("plots", "plots"), ("cases", "all cases")))
    body = "".join([
        "<h1>Build HAT serial protocol — conformance report</h1>",
        f"<p class=muted>buildhat-conformance {_e(tool_version)} · built {_e(now)} · {len(runs)} run(s)</p>",
        f"<p>{nav}</p>",
        _runs_section(runs),
        _coverage_section(cov, runs),
        _case_list("Failures", "failures", failures, excerpts, "No failures."),
        _deviations_section(deviations, excerpts),
        _plots_section(plots, have_png),
        _side_by_side(runs),
    ])
    return ("<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8>"
            "<title>Build HAT conformance report</title>"
            f"<style>{_CSS}</style></head><body>{body}</body></html>\n")
