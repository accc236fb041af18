"""``buildhat-conformance replay FILE --target URL``: send a transcript's host bytes again, at the
recorded times (scaled by the target's time scale), and diff what comes back.

World actions (plugging, faults, sensor data) cannot be seen in a transcript from hardware. A
transcript the emulator wrote in script mode names its script in ``meta.script``; a transcript
recorded through a session carries ``world ...`` notes. Either gives the world actions and their
times; a target without the matching control capability cannot replay such a transcript
faithfully, and replay says what is missing instead of pretending (``--without-world`` replays
the host bytes alone, and says so).

The replay runs through the one script runner (transcripts/script_runner.py), as ``script`` and
``record`` do: each recorded host line at its recorded time, in virtual time on ``inprocess``
(deterministic), in real time on every other target.
The comparison (transcripts/compare.py) starts after the recording's first host line at t >= 0:
the start-up before it depends on when the target was switched on, not on the protocol.
"""
from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

from ..harness.errors import TargetError
from ..harness.transcript import Transcript, field_bytes, read_transcript
from ..plumbing.cli_options import BOOT_TIMEOUT_S
from .compare import Comparison, RuleSet, Unit, compare_units, output_units
from .script import Action, Script, escape_raw, load_script, parse_script, parse_world_action
from .script_runner import run_script

__all__ = ["Step", "Plan", "plan_replay", "plan_script", "missing_capabilities", "replay",
           "compare_transcripts", "units_after_first_host", "write_transcript"]

WORLD_NOTE = "world "   # Session.world() notes: "world @plug 1 0x30 -> ok"


@dataclass(frozen=True)
class Step:
    t: float          # HAT ms from the script start
    kind: str         # send | world
    data: bytes = b""
    line: str = ""    # the world action, as a script line


@dataclass
class Plan:
    steps: List[Step]
    end_t: float
    world_source: str                       # script | notes | none
    layout: Optional[Dict[int, Optional[tuple]]] = None
    remarks: List[str] = field(default_factory=list)

    @property
    def world_kinds(self) -> List[str]:
        return sorted({s.line.split()[0].lstrip("@") for s in self.steps if s.kind == "world"})


def _find_script(ref: str, transcript_path: Optional[str]) -> Optional[str]:
    candidates = [ref]
    if transcript_path:
        here = os.path.dirname(os.path.abspath(transcript_path))
        candidates += [os.path.join(here, ref), os.path.join(here, os.path.basename(ref))]
    return next((c for c in candidates if os.path.isfile(c)), None)


def script_steps(script: Script) -> List[Step]:
    steps, t = [], 0.0
    for a in script.actions:
        if a.kind == "wait":
            t += a.args[0]
        elif a.kind == "send":
            steps.append(Step(t, "send", a.data))
        else:
            steps.append(Step(t, "world", line=a.text.strip()))
    return steps


def plan_replay(transcript: Transcript, transcript_path: Optional[str] = None,
                script: Optional[Script] = None) -> Plan:
    """What to do when: the recorded host bytes (t >= 0), plus world actions from the script
    (``meta.script`` or ``script``) or from the session's ``world`` notes."""
    host = [(float(e["t"]), field_bytes(e, "bytes")) for e in transcript.events
            if e.get("dir") == "host" and float(e.get("t", 0)) >= 0]
    end_t = max([float(e.get("t", 0)) for e in transcript.events] + [0.0])
    remarks: List[str] = []
    ref = transcript.meta.get("script")
    if script is None and isinstance(ref, str) and ref:
        found = _find_script(ref, transcript_path)
        if found:
            script = load_script(found)
        elif "\n" in ref:
            script = parse_script(ref, "<meta.script>")
        else:
            remarks.append(f"the recording names script {ref!r}, which is not found; "
                           "world actions come from the notes, if any")
    layout: Optional[Dict[int, Optional[tuple]]] = None
    devices = transcript.meta.get("devices")
    if isinstance(devices, dict):
        from ..protocol.devices import parse_device_spec

        layout = {int(p): parse_device_spec(str(s)) for p, s in devices.items()}
    if script is not None:
        steps = script_steps(script)
        sent = b"".join(s.data for s in steps if s.kind == "send")
        if sent != b"".join(d for _t, d in host):
            raise ValueError(f"script {script.source} does not send what the transcript's host events "
                             "hold; name the right one with --script")
        # The recorded times are what the target saw; keep them for the sends.
        it = iter(host)
        steps = [Step(next(it)[0], "send", s.data) if s.kind == "send" else s for s in steps]
        layout = layout or dict(script.devices)
        return Plan(steps, end_t, "script", layout, remarks)
    steps = [Step(t, "send", d) for t, d in host]
    for e in transcript.events:
        text = e.get("text", "")
        if e.get("dir") == "note" and text.startswith(WORLD_NOTE) and float(e.get("t", 0)) >= 0:
            line = text[len(WORLD_NOTE):].split(" -> ")[0].strip()
            parse_world_action(line)   # refuse notes that are not world actions
            steps.append(Step(float(e["t"]), "world", line=line))
    steps.sort(key=lambda s: s.t)     # stable: a world note written after a send stays after it
    src = "notes" if any(s.kind == "world" for s in steps) else "none"
    return Plan(steps, end_t, src, layout, remarks)


def missing_capabilities(plan: Plan, target) -> List[str]:  # type: ignore[no-untyped-def]
    """World-action kinds the plan needs that the target cannot perform."""
    return [k for k in plan.world_kinds if not target.has(k)]


def plan_script(plan: Plan, name: str = "") -> Script:
    """The plan as a scenario for the one script runner (transcripts/script_runner.py): each
    step at its recorded time (the waits are the gaps), the recording's start-up layout."""
    script = Script(name=name, source="<replay>")
    if plan.layout:
        script.devices.update(plan.layout)
    t = 0.0
    for step in plan.steps:
        if step.t > t:
            script.actions.append(Action("wait", (step.t - t,), text=f"@wait {step.t - t:g}"))
            t = step.t
        if step.kind == "send":
            script.actions.append(Action("send", (), step.data, text=f">raw {escape_raw(step.data)}"))
        else:
            script.actions.append(parse_world_action(step.line))
    return script


def write_transcript(transcript: Transcript, path: str) -> None:
    """Save a transcript (meta first)."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", encoding="utf-8") as fh:
        for obj in [dict({"dir": "meta"}, **{k: v for k, v in transcript.meta.items() if k != "dir"})] \
                + transcript.events:
            fh.write(json.dumps(obj, ensure_ascii=True, separators=(",", ":")) + "\n")


def replay(transcript: Transcript, target, plan: Optional[Plan] = None,  # type: ignore[no-untyped-def]
           out: Optional[str] = None,
           boot_timeout: float = BOOT_TIMEOUT_S) -> Tuple[Transcript, float, List[str]]:
    """Replay a recording on a target through the script runner; returns (what came back,
    slack in HAT ms for cutting real-time output, remarks). ``boot_timeout``: HAT seconds a
    booting target has to bring up the recording's layout."""
    plan = plan or plan_replay(transcript)
    source = transcript.meta.get("name") or transcript.meta.get("script") or ""
    meta = {"tool": f"buildhat-conformance {_tool_version()} replay", "replay_of": source,
            "script": None}
    buf = io.StringIO()
    result = run_script(plan_script(plan, str(source)), target, transcript=buf, meta=meta,
                        layout_wait_s=boot_timeout, end_ms=plan.end_t)
    remarks = list(plan.remarks) + list(result.notes)
    if not result.ok:
        raise TargetError(result.reason)
    slack = 0.0
    if not result.virtual:
        slack = result.late_ms + 20.0
    if result.late_ms > 10.0:
        remarks.append(f"a step went out up to {result.late_ms:.0f} ms (HAT time) after its recorded time; "
                       "output timed from it shifts by as much")
    actual = read_transcript(io.StringIO(buf.getvalue()))
    actual.meta = {k: v for k, v in actual.meta.items() if v is not None}
    if out:
        write_transcript(actual, out)
    return actual, slack, remarks


def _tool_version() -> str:
    from ..plumbing.package_version import __version__

    return __version__


# -- comparison ------------------------------------------------------------------------------
def units_after_first_host(transcript: Transcript, include_startup: bool = False) -> List[Unit]:
    """Output lines after the first host event at t >= 0 (everything with include_startup)."""
    events = transcript.events
    if not include_startup:
        idx = next((i for i, e in enumerate(events)
                    if e.get("dir") == "host" and float(e.get("t", 0)) >= 0), len(events))
        events = events[idx:]
    return output_units(events, since=float("-inf"))


def compare_transcripts(expected: Transcript, actual: Transcript, rules: RuleSet, classify=None,
                        include_startup: bool = False, trim_after: Optional[float] = None) -> Comparison:
    """Compare the HAT output of two transcripts. ``trim_after`` (HAT ms): extra lines at the very
    end that came after this time are outside the recorded window (a real-time target keeps
    talking while the replay winds down), so they are not counted as differences."""
    exp = units_after_first_host(expected, include_startup)
    act = units_after_first_host(actual, include_startup)
    result = compare_units(exp, act, rules, classify)
    if trim_after is not None:
        ops = result.ops
        while ops and ops[-1][0] == "extra" and ops[-1][2] is not None and ops[-1][2].t > trim_after:
            ops.pop()
    return result
