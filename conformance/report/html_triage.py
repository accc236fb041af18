"""The report's first screen: what the run says, what changed since the previous run of the
same target, what failed and why (grouped by first differing line, each with the exchange
that failed), target faults, skips with what to connect; and the legend of every code."""
from __future__ import annotations

import difflib
import re
from typing import Dict, List, Optional, Sequence, Tuple

from .junit import VERDICTS, Case, JunitRun
from .markup import LABEL, LETTER, MEANING, esc, names, tag, tests_cell
from .triage import MODULE_PATH, NOTHING, Change, Exchange, FailureGroup, headline, scrub, skip_reasons

__all__ = ["summary_section", "failure_groups_section", "by_requirement_section", "faults_section",
           "skips_section", "legend_section", "exchange_html"]

MAX_REPLY = 12     # lines of a reply shown in an exchange; the transcript has the rest


def _verdict_word(runs: Sequence[JunitRun]) -> Tuple[str, str]:
    counts = {v: sum(r.counts()[v] for r in runs) for v in VERDICTS}
    if counts["fail"]:
        return "fail", f"FAILS: {counts['fail']} finding(s) against the protocol"
    if counts["target_fault"] or counts["not_run"]:
        return "target_fault", "INCOMPLETE: the target faulted; see target faults"
    if not any(counts.values()):
        return "skip", "NOTHING RAN"
    return "pass", "CONFORMS (known deviations and informational results aside)"


def summary_section(runs: Sequence[JunitRun], changes: Dict[str, Optional[Tuple[str, List[Change]]]],
                    built: str) -> str:
    cls, word = _verdict_word(runs)
    targets = "; ".join(f"{r.target or '?'} · firmware {r.firmware or '?'} · profile {r.profile or '?'}"
                        for r in runs)
    counts = {v: sum(r.counts()[v] for r in runs) for v in VERDICTS}
    order = ("fail", "target_fault", "not_run", "pass", "known_deviation", "informational", "skip")
    chips = "".join(
        f'<a class="chip {v if counts[v] else "zero"}" href="#{_anchor(v)}" title="{esc(MEANING[v])}">'
        f'<b>{counts[v]}</b> {esc(LABEL[v])}</a>' for v in order)
    parts = [f'<h1><span class="verdict {cls}">{esc(word)}</span></h1>',
             f'<p class=target>{esc(targets)}</p>',
             f'<p class=chips>{chips} <span class=muted>· {sum(counts.values())} cases · {esc(built)}'
             ' · <a href="#legend">legend</a></span></p>']
    for run in runs:
        parts.append(_judged_line(run))
        parts.append(_changes_line(run, changes.get(run.path)))
    return "<header>" + "".join(parts) + "</header>"


def _judged_line(run: JunitRun) -> str:
    """A clause the harness relies on that broke (the `version` line first of all: it chooses the
    profile) and how the profile was chosen when the version did not name it: what every other
    verdict of the run rests on, so on the first screen."""
    bits = []
    for key, label in (("broken_clauses", "clause the harness relies on broke"),
                       ("profile_why", f"judged as {run.profile or '?'}")):
        value = (run.properties.get(key) or [""])[0]
        if value:
            bits.append(f"<b class=warn>{esc(label)}</b>: {esc(value)}")
    return f"<p class=judged>{'<br>'.join(bits)}</p>" if bits else ""


def _anchor(verdict: str) -> str:
    return {"fail": "failures", "target_fault": "faults", "not_run": "faults", "skip": "skips",
            "known_deviation": "deviations"}.get(verdict, "cases")


def _changes_line(run: JunitRun, found: Optional[Tuple[str, List[Change]]]) -> str:
    if found is None:
        return ("<p class='changes muted'>No earlier run of this target in the same reports folder to "
                "compare with.</p>")
    prev_name, changes = found
    if not changes:
        return (f"<p class=changes>Since the previous run of this target ({esc(prev_name)}): "
                "no verdict changed.</p>")
    worse = [c for c in changes if c.after in ("fail", "target_fault") and c.before not in ("fail",)]
    better = [c for c in changes if c.before in ("fail", "target_fault") and c.after == "pass"]
    other = [c for c in changes if c not in worse and c not in better]

    def listed(cs: List[Change]) -> str:
        shown = ", ".join(f"{c.test_id.split('::')[-1]} ({LABEL.get(c.before, c.before)} → "
                          f"{LABEL.get(c.after, c.after)})" for c in cs[:6])
        return shown + (f", … {len(cs) - 6} more" if len(cs) > 6 else "")
    bits = []
    if worse:
        bits.append(f"<b class=warn>{len(worse)} newly failing</b>: {esc(listed(worse))}")
    if better:
        bits.append(f"<b>{len(better)} fixed</b>: {esc(listed(better))}")
    if other:
        bits.append(f"{len(other)} other change(s): {esc(listed(other))}")
    return (f"<p class=changes>Since the previous run of this target ({esc(prev_name)}): "
            f"{'; '.join(bits)}.</p>")


def _aligned(expected: List[str], received: List[str]) -> List[Tuple[str, str, bool]]:
    """Rows of (expected, received, differs), aligned by a line diff."""
    rows: List[Tuple[str, str, bool]] = []
    sm = difflib.SequenceMatcher(a=expected, b=received, autojunk=False)
    for op, i1, i2, j1, j2 in sm.get_opcodes():
        a, b = expected[i1:i2], received[j1:j2]
        for k in range(max(len(a), len(b))):
            rows.append((a[k] if k < len(a) else NOTHING, b[k] if k < len(b) else NOTHING, op != "equal"))
    return rows


def _line(text: str) -> str:
    if text == NOTHING:
        return '<span class=muted>(nothing)</span>'
    return esc(text) if text else '<span class=muted>(empty line)</span>'


def exchange_html(ex: Exchange) -> str:
    """The command sent, then expected and received side by side; the first differing line marked."""
    sent = (f'<div class=sent><span class=lbl>sent</span><code>&gt; {esc(ex.sent)}</code></div>'
            if ex.sent else "")
    if ex.expected is not None and ex.received is not None:
        rows, first = [], True
        for want, got, differs in _aligned(ex.expected, ex.received)[:MAX_REPLY * 2]:
            cls = ""
            if differs:
                cls = " class=first" if first else " class=diff"
                first = False
            rows.append(f"<tr{cls}><td>{_line(want)}</td><td>{_line(got)}</td></tr>")
        body = ("<table class=xr><tr><th>expected</th><th>received from the target</th></tr>"
                + "".join(rows) + "</table>")
    elif ex.reply:
        # A window of the reply that holds the wrong line (marked), else its beginning.
        start = max(0, min(ex.mark - MAX_REPLY // 2, len(ex.reply) - MAX_REPLY)) if ex.mark >= 0 else 0
        shown = ex.reply[start:start + MAX_REPLY]
        before = f"<span class=muted>… {start} line(s) before</span><br>" if start else ""
        after = len(ex.reply) - start - len(shown)
        more = f"<br><span class=muted>… {after} more line(s)</span>" if after else ""
        lines = [f"<span class=first>&lt; {_line(s)}</span>" if start + i == ex.mark else "&lt; " + _line(s)
                 for i, s in enumerate(shown)]
        body = ("<div class=reply><span class=lbl>received</span><code>" + before
                + "<br>".join(lines) + f"</code>{more}</div>")
    else:
        body = ""
    return f"<div class=exchange>{sent}{body}</div>"


def _clip(text: str, n: int) -> str:
    return text if len(text) <= n else text[:n - 1] + "…"


def _few(items: List[str], n: int) -> Tuple[List[str], int]:
    return items[:n], max(0, len(items) - n)


def failure_groups_section(groups: List[FailureGroup]) -> str:
    if not groups:
        return "<h2 id=failures>What failed</h2><p class=muted>No failures.</p>"
    total = sum(len(g.members) for g in groups)
    rows = []
    for g in groups:
        _run, case, ex = g.example
        tests, more_tests = _few(tests_cell([(r.label, c) for r, c, _e in g.members]).split(", "), 4)
        reqs, more_reqs = _few(g.requirements, 6)
        req_html = ", ".join(f'<a href="#req-{esc(r)}">{esc(r)}</a>' for r in reqs) + \
            (f" <span class=muted>+{more_reqs} more</span>" if more_reqs else "")
        # An assertion's group is named by its differing line, the example adds its reason; a
        # reason-named group shows the example's own words (the key has its numbers taken out).
        title = g.key if ex.expected is not None else _clip(ex.why, 220)
        why = f"e.g. <code>{esc(case.name)}</code>" \
            + (f": {esc(_clip(ex.why, 220))}" if ex.why != title else "")
        rows.append(
            f'<tr><td class=n><b>{len(g.members)}</b></td>'
            f'<td><b>{esc(title)}</b><div class=why>{why}</div>'
            f'<div class=tests>requirements: {req_html}</div></td>'
            f'<td>{exchange_html(ex)}</td><td class=tests>{names(", ".join(tests))}'
            + (f" <span class=muted>… +{more_tests} more</span>" if more_tests else "") + "</td></tr>")
    return (f"<h2 id=failures>What failed: {total} case(s), {len(groups)} kind(s), "
            "by first differing line</h2>"
            "<table class=groups><colgroup><col style='width:3.5em'><col style='width:36%'>"
            "<col style='width:38%'><col></colgroup>"
            "<tr><th>n</th><th>first differing line (or reason) · example · requirements</th>"
            "<th>the exchange that failed (example)</th><th>tests</th></tr>"
            + "".join(rows) + "</table>"
            "<p class=muted>Every failing case, with its own exchange and transcript, is under "
            "<a href='#by-requirement'>failures by requirement</a>.</p>")


def by_requirement_section(groups: List[FailureGroup], statements: Dict[str, str],
                           excerpts: Dict[int, List[str]]) -> str:
    """Every failing case under the first requirement it cites, with its exchange; the transcript
    excerpt one click away."""
    per_req: Dict[str, List[Tuple[JunitRun, Case, Exchange]]] = {}
    for g in groups:
        for member in g.members:
            req = member[1].requirements[0] if member[1].requirements else "(no requirement ID)"
            per_req.setdefault(req, []).append(member)
    if not per_req:
        return ""
    parts = ["<h2 id=by-requirement>Failures by requirement</h2>"]
    for req, members in sorted(per_req.items(), key=lambda kv: -len(kv[1])):
        parts.append(f"<details><summary><b>{esc(req)}</b> — {len(members)} case(s) "
                     f"<span class=muted>{esc(statements.get(req, ''))}</span></summary>")
        for run, case, ex in members:
            parts.append(f"<div class=case><p>{tag('fail')} <code>{esc(case.test_id)}</code> "
                         f"<span class=muted>{esc(run.label)} · "
                         f"{esc(', '.join(case.requirements))}</span></p>"
                         f"<p class=why>{esc(ex.why)}</p>{exchange_html(ex)}")
            lines = excerpts.get(id(case))
            if lines:
                parts.append(f"<details><summary>transcript <code>{esc(case.transcript)}</code></summary>"
                             f"<pre>{esc(chr(10).join(lines))}</pre></details>")
            parts.append("</div>")
        parts.append("</details>")
    return "".join(parts)


def _fault_detail(case: Case) -> str:
    """The error as raised, up to its chained repeats: it carries the target's last stderr lines."""
    text = case.detail.split("\n\nThe above exception was the direct cause", 1)[0].strip()
    return scrub(MODULE_PATH.sub("", text))[:3000]


def faults_section(items: List[Tuple[JunitRun, Case]]) -> str:
    """Each target fault with what happened (and the error in full, one click away); the cases
    not run after it grouped by their reason."""
    if not items:
        return ""
    rows = []
    for _r, c in items:
        if c.verdict != "target_fault":
            continue
        detail = _fault_detail(c)
        # A target program's last stderr lines say why it died: shown, not behind a click.
        _before, _s, tail = detail.partition("its last stderr lines:")
        stderr = [ln.strip() for ln in tail.splitlines() if ln.strip()][-8:]
        more = (f"<pre>{esc(chr(10).join(stderr))}</pre>" if stderr else "") + (
            f"<details><summary>the error in full</summary><pre>{esc(detail)}</pre></details>"
            if detail else "")
        rows.append(f"<tr><td>{tag(c.verdict)}</td><td><code>{esc(c.test_id)}</code></td>"
                    f"<td>{esc(headline(c))}{more}</td></tr>")
    not_run: Dict[str, List[Case]] = {}
    for _r, c in items:
        if c.verdict == "not_run":
            reason = re.sub(r"^(NotRun: )?(not run: )?", "", headline(c))
            not_run.setdefault(reason, []).append(c)
    for reason, cases in not_run.items():
        rows.append(f"<tr><td>{tag('not_run')}</td><td><b>{len(cases)}</b> case(s): "
                    f"<span class=tests>{esc(_clip(tests_cell([('', c) for c in cases]), 400))}</span></td>"
                    f"<td>{esc(reason)}</td></tr>")
    return ("<h2 id=faults>Target faults and cases not run</h2><p class=muted>The target (or the link) "
            "failed here: silent, dead, rebooted or garbled. These are not protocol findings; fix the "
            "setup and run again.</p><table class=wide><colgroup><col style='width:9em'>"
            "<col style='width:35%'>"
            "<col></colgroup><tr><th>verdict</th><th>case</th><th>what happened</th></tr>"
            f"{''.join(rows)}</table>")


def skips_section(items: List[Tuple[JunitRun, Case]]) -> str:
    if not items:
        return ""
    rows = "".join(f"<tr><td class=n>{len(cases)}</td><td>{esc(reason)}</td>"
                   f"<td class=tests>{esc(tests_cell([('', c) for c in cases]))}</td></tr>"
                   for reason, cases in skip_reasons(items))
    return ("<h2 id=skips>Skipped: what to connect to run them</h2><table class=wide><colgroup>"
            "<col style='width:4.8em'><col style='width:45%'><col></colgroup>"
            f"<tr><th>cases</th><th>reason (what the case needs)</th><th>tests</th></tr>{rows}</table>")


def legend_section() -> str:
    verdicts = "".join(f"<tr><td>{tag(v)}</td><td><code>{esc(LETTER[v])}</code></td>"
                       f"<td>{esc(MEANING[v])}</td></tr>"
                       for v in ("pass", "fail", "target_fault", "not_run", "skip", "known_deviation",
                                 "informational"))
    statuses = "".join(f"<tr><td>{tag(v)}</td><td>{esc(MEANING[v])}</td></tr>" for v in ("hole", "untested"))
    return (
        "<h2 id=legend>Legend</h2><table class=wide><colgroup><col style='width:11em'><col style='width:6em'>"
        "<col></colgroup><tr><th>verdict</th><th>terminal letter</th><th>meaning</th></tr>"
        f"{verdicts}<tr><td colspan=2><code>E</code> (terminal)</td><td>an error in a case's set-up or "
        "tear-down; the report counts it as fail</td></tr></table>"
        "<table class=wide><colgroup><col style='width:11em'><col></colgroup><tr><th>coverage status</th>"
        f"<th>meaning</th></tr>{statuses}<tr><td>fail / known deviation / pass</td><td>the worst verdict of "
        "the cases citing the requirement, in that order</td></tr></table>"
        "<table class=wide><colgroup><col style='width:11em'><col></colgroup><tr><th>column or sign</th>"
        "<th>meaning</th></tr>"
        "<tr><td><code>obs</code></td><td>how a black-box tester observes the requirement on a real HAT: "
        "<code>wire</code> in the command-port text; <code>debug</code> through <code>debug</code> "
        "output (PID lines); <code>device</code> needs a device on a port and its mode data; "
        "<code>rig</code> needs something outside the HAT (plugging, a power fault, a meter). "
        "The emulator provides all four.</td></tr>"
        "<tr><td><code>&gt;</code> / <code>&lt;</code></td><td>a line the host sent / a line the target "
        "printed (transcript excerpts: <code>~</code> a line not ended by CRLF, <code>#</code> a note)"
        "</td></tr>"
        "<tr><td><span class='first legendmark'>marked row</span></td><td>the first line where what was "
        "received differs from what was expected; later differing rows are shaded lighter</td></tr>"
        "<tr><td><code>test_x ×12</code></td><td>twelve parametrized cases of one test</td></tr>"
        "<tr><td>by run (1..N)</td><td>with several runs in one report: the requirement's status in each "
        "run, numbered as in the runs table</td></tr>"
        "<tr><td>T fault, not run, known dev., info</td><td>the verdict columns: target fault, not run, "
        "known deviation, informational (above)</td></tr>"
        "<tr><td><code>…#fb-on-off</code></td><td>a section of docs/FIRMWARE-BEHAVIOUR.md, the project's "
        "record of how each firmware release behaves, named by its anchor</td></tr></table>")
