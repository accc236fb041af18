"""Writing findings: a scenario script (docs/formats/SCENARIO-SCRIPT.md) that replays the shrunk
failing run, one transcript per target (docs/formats/TRANSCRIPT.md), and the JUnit file with one
test case per oracle.

The script holds exactly the bytes the fuzzer sent, one line per CR-terminated line (``>`` for
plain text, ``>raw`` otherwise), with ``@wait`` for the HAT time that passed between them, so
``buildhat-conformance script`` (or :func:`fuzz.replay.replay_script`) reproduces the run.
"""
from __future__ import annotations

import os
import re
from typing import Dict, List, Optional, Sequence
from xml.sax.saxutils import escape, quoteattr

from ...harness.transcript import TranscriptWriter
from ...protocol.devices import DEFAULT_LAYOUT
from ...transcripts.script import Action, Script, format_action, parse_script
from ..oracles.registry import Finding, oracle_names
from ..running.target_exchange import Trace

__all__ = ["script_text", "script_from_trace", "write_finding", "write_transcript", "write_junit",
           "split_lines"]


def split_lines(data: bytes) -> List[bytes]:
    """Cut sent bytes after every CR (the script format has one line per action)."""
    out, start = [], 0
    for i, b in enumerate(data):
        if b == 0x0D:
            out.append(data[start:i + 1])
            start = i + 1
    if start < len(data):
        out.append(data[start:])
    return out


def _device_line(port: int, spec: Optional[tuple]) -> str:
    if spec is None:
        return f"@device {port} none"
    kind, value = spec
    return f"@device {port} 0x{value:02X}" if kind == "active" else f"@device {port} passive {value}"


def script_text(finding: Finding, trace: Trace, header: Sequence[str] = (),
                devices: Optional[Dict[int, Optional[tuple]]] = None) -> str:
    lines = [f";; {h}" for h in header]
    first = finding.message.splitlines()[0] if finding.message else finding.oracle
    lines.append(f"@name fuzz finding ({finding.oracle}): {re.sub(r'[^ -~]', '?', first)[:160]}")
    if devices is not None:
        layout = dict(DEFAULT_LAYOUT)
        layout.update(devices)
        lines += [_device_line(p, layout.get(p)) for p in range(4)]
    last_t: Optional[float] = None
    for kind, t, value in trace.entries:
        if kind == "wait":
            assert isinstance(value, (int, float))      # ('wait', t_ms, ms)
            lines.append(format_action(Action("wait", (float(value),))))
            last_t = t + float(value)
            continue
        if kind != "send":
            continue
        if last_t is not None and t - last_t >= 1:
            lines.append(format_action(Action("wait", (float(int(t - last_t)),))))
        last_t = t
        for piece in split_lines(value):  # type: ignore[arg-type]
            lines.append(format_action(Action("send", (), piece)))
    return "\n".join(lines) + "\n"


def script_from_trace(finding: Finding, devices: Optional[Dict[int, Optional[tuple]]] = None) -> Script:
    """The run that failed (its first target's trace) as a script, for replays."""
    return parse_script(script_text(finding, finding.traces[0], (), devices), source="<finding>")


def write_transcript(path: str, trace: Trace, meta: dict) -> str:
    entries = trace.entries
    t0 = entries[0][1] if entries else 0.0
    with TranscriptWriter(path, meta) as tw:
        end = 0.0
        for kind, t, value in entries:
            rel = t - t0
            if kind in ("send", "sync"):
                tw.host(rel, value)  # type: ignore[arg-type]
            elif kind == "recv":
                tw.hat(rel, value)  # type: ignore[arg-type]
            elif kind == "wait":
                tw.note(rel, f"@wait {value}")
            end = max(end, rel)
        tw.end(end)
    return path


def write_finding(finding: Finding, outdir: str, header: Sequence[str], meta: dict,
                  devices: Optional[Dict[int, Optional[tuple]]] = None) -> Dict[str, str]:
    """Files for one finding: ``<oracle>.script`` and ``<oracle>.<target label>.jsonl`` per trace."""
    os.makedirs(outdir, exist_ok=True)
    paths: Dict[str, str] = {}
    if not finding.traces:
        return paths
    script = os.path.join(outdir, f"{finding.oracle}.script")
    with open(script, "w", encoding="utf-8") as fh:
        fh.write(script_text(finding, finding.traces[0], header, devices))
    paths["script"] = script
    for trace in finding.traces:
        p = os.path.join(outdir, f"{finding.oracle}.{trace.label}.jsonl")
        write_transcript(p, trace, dict(meta, oracle=finding.oracle, finding=finding.message,
                                        target_label=trace.label))
        paths[trace.label] = p
    reports = finding.details.get("reports")
    if reports:       # a firmware in the loop's sanitizer reports (or crash), whole
        p = os.path.join(outdir, f"{finding.oracle}.report.txt")
        with open(p, "w", encoding="utf-8") as fh:
            fh.write("\n\n".join(reports) + "\n")
        paths["report"] = p
    expected = finding.details.get("expected")
    if expected:
        p = os.path.join(outdir, f"{finding.oracle}.expected.txt")
        with open(p, "w", encoding="utf-8") as fh:
            fh.write(f"step sent: {finding.details.get('step')!r}\n")
            fh.write("model's prediction, in order:\n")
            for item in expected:
                fh.write(f"  [{item.oracle}] {item.describe()}\n")
            fh.write(f"received: {finding.details.get('received')!r}\n")
        paths["expected"] = p
    return paths


def write_junit(path: str, oracles: Sequence[str], findings: Sequence[Finding], checks: Dict[str, int],
                elapsed: float, properties: Dict[str, str], files: Dict[str, Dict[str, str]],
                not_done: Optional[str] = None, notes: Optional[Dict[str, str]] = None) -> str:
    """One test case per oracle: a failure carries the finding, the files to replay it and the
    oracle's line in ``notes`` (how often it reproduced). A campaign that could not do its job
    (``not_done``) adds a ``campaign`` case in error saying why."""
    unknown = set(oracles) - set(oracle_names())
    if unknown:
        raise ValueError(f"unknown oracles {sorted(unknown)}")
    by_oracle = {f.oracle: f for f in findings}
    cases = []
    for oracle in oracles:
        f = by_oracle.get(oracle)
        body = ""
        if f is not None:
            where = "; ".join(f"{k}: {v}" for k, v in files.get(oracle, {}).items())
            if notes and notes.get(oracle):
                where += f"\n{notes[oracle]}"
            body = (f'<failure message={quoteattr(f.message[:500])} type="fuzz.{oracle}">'
                    f"{escape(f.message)}\n{escape(where)}</failure>")
        elif not checks.get(oracle):
            body = '<skipped message="no check of this oracle ran"/>'
        cases.append(f'  <testcase classname="fuzz" name={quoteattr(oracle)} time="{elapsed:.3f}">'
                     f'<system-out>{checks.get(oracle, 0)} checks</system-out>{body}</testcase>')
    if not_done:
        cases.append(f'  <testcase classname="fuzz" name="campaign" time="{elapsed:.3f}">'
                     f'<error message={quoteattr(not_done)} type="fuzz.not_done"/></testcase>')
    props = "".join(f"<property name={quoteattr(k)} value={quoteattr(str(v))}/>"
                    for k, v in properties.items())
    failures = sum(1 for o in oracles if o in by_oracle)
    skipped = sum(1 for o in oracles if o not in by_oracle and not checks.get(o))
    errors = 1 if not_done else 0
    xml = ('<?xml version="1.0" encoding="utf-8"?>\n'
           f'<testsuite name="fuzz" tests="{len(cases)}" failures="{failures}" errors="{errors}" '
           f'skipped="{skipped}" time="{elapsed:.3f}">\n  <properties>{props}</properties>\n'
           + "\n".join(cases) + "\n</testsuite>\n")
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(xml)
    return path
