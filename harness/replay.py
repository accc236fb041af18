"""``buildhat-conformance replay FILE --target URL``: send a transcript's host bytes again, at the
recorded times (scaled by the target's time scale), and diff what comes back.

World actions (plugging, faults, sensor data) cannot be seen in a transcript from hardware. A
transcript the emulator wrote in script mode names its script in ``meta.script``; a transcript
recorded through a session carries ``world ...`` notes. Either gives the world actions and their
times; a target without the matching control capability cannot replay such a transcript
faithfully, and replay says what is missing instead of pretending (``--without-world`` replays
the host bytes alone, and says so).

Two drivers: targets in virtual time (``inprocess``) are stepped to each recorded millisecond,
which makes the replay deterministic; every other target runs in real time through a Session.
The comparison (harness/compare.py) starts after the recording's first host line at t >= 0:
the start-up before it depends on when the target was switched on, not on the protocol.
"""
from __future__ import annotations

import argparse
import io
import json
import os
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

from .compare import Comparison, RuleSet, Unit, compare_units, output_units
from .script import Script, load_script, parse_script, parse_world_action
from .transcript import Transcript, TranscriptWriter, field_bytes, read_transcript

__all__ = ["Step", "Plan", "plan_replay", "missing_capabilities", "replay", "compare_transcripts",
           "units_after_first_host", "run_plan", "write_transcript", "add_arguments", "main"]

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


# -- drivers ---------------------------------------------------------------------------------
def _replay_virtual(plan: Plan, target, writer: TranscriptWriter) -> None:  # type: ignore[no-untyped-def]
    """Step an in-process emulator to each recorded millisecond: deterministic."""
    start_out = target.read(0)
    if start_out:
        writer.hat(-1, start_out)
        writer.flush_partial(-1)
    origin = target.now

    def run_to(t_goal: float) -> None:
        while target.now - origin < t_goal:
            left = t_goal - (target.now - origin)
            data = target.read(left / 1000.0 / target.time_scale)
            if data:
                writer.hat(target.now - origin, data)

    for step in plan.steps:
        run_to(step.t)
        if step.kind == "send":
            writer.host(target.now - origin, step.data)
            target.write(step.data)
        else:
            reply = target.control.action(step.line)
            writer.note(target.now - origin, f"world {step.line} -> {reply}")
        data = target.read(0)
        if data:
            writer.hat(target.now - origin, data)
    run_to(plan.end_t)
    writer.end(target.now - origin)


class _Reader:
    """Reads a real-time target on a thread, keeping every chunk with the time it came."""

    def __init__(self, target) -> None:  # type: ignore[no-untyped-def]
        self.target = target
        self.chunks: List[Tuple[float, str, bytes]] = []   # (monotonic s, dir, bytes)
        self.error: Optional[BaseException] = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="replay-reader", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self.target.read(0.05)
            except Exception as exc:  # noqa: BLE001 - the target went away; the caller reports it
                self.error = exc
                return
            if data:
                self.add("hat", data)

    def add(self, kind: str, data: bytes) -> None:
        with self._lock:
            self.chunks.append((time.monotonic(), kind, data))

    def seen_line(self, line: str) -> bool:
        with self._lock:
            stream = b"".join(d for _t, k, d in self.chunks if k == "hat")
        return (b"\r\n" + line.encode("utf-8") + b"\r\n") in b"\r\n" + stream

    def wait_quiet(self, quiet: float, limit: float) -> None:
        """Until nothing has arrived for ``quiet`` seconds, or ``limit`` seconds have passed."""
        end = time.monotonic() + limit
        while time.monotonic() < end:
            with self._lock:
                last = self.chunks[-1][0] if self.chunks else 0.0
            if time.monotonic() - last >= quiet:
                return
            time.sleep(0.02)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)


def _replay_realtime(plan: Plan, target, writer: TranscriptWriter, ready: Sequence[str],
                     boot_timeout: float) -> Tuple[float, Optional[str]]:  # type: ignore[no-untyped-def]
    """Sleep to each recorded time / time scale. Returns the lateness of the last step (HAT ms)
    and a remark when the recorded start-up was not seen."""
    target.open()
    reader = _Reader(target)
    remark = None
    try:
        if ready and boot_timeout > 0:
            # A target that talks as soon as it is opened is booting (a fresh emulator): wait for
            # the start-up lines the script needs. One that stays silent is already running
            # (hardware) and will never print them.
            deadline = time.monotonic() + boot_timeout
            talking = time.monotonic() + min(1.0, boot_timeout)
            while not reader.chunks and time.monotonic() < talking:
                time.sleep(0.02)
            while reader.chunks and time.monotonic() < deadline and \
                    not all(reader.seen_line(line) for line in ready):
                time.sleep(0.02)
            unseen = [line for line in ready if not reader.seen_line(line)]
            if not reader.chunks:
                remark = "the target said nothing when opened: taken as already running"
            elif unseen:
                remark = f"start-up line(s) {unseen!r} did not arrive within {boot_timeout:g} s; went on"
        scale = float(target.time_scale or 1.0)
        t0 = time.monotonic()
        late = 0.0
        for step in plan.steps:
            wait = t0 + step.t / 1000.0 / scale - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            late = max(late, (time.monotonic() - t0) * 1000.0 * scale - step.t)
            if step.kind == "send":
                reader.add("host", step.data)
                target.write(step.data)
            else:
                reply = target.control.action(step.line)
                reader.add("note", f"world {step.line} -> {reply}".encode())
        wait = t0 + plan.end_t / 1000.0 / scale - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        reader.wait_quiet(0.3, 3.0)   # answers still on their way (shared noisy cores)
    finally:
        reader.stop()
    if reader.error is not None:
        raise reader.error
    write_chunks(writer, reader.chunks, t0, scale)   # HAT ms; the start-up comes out at t < 0
    writer.end((time.monotonic() - t0) * 1000.0 * scale)
    return late, remark


def write_chunks(writer: TranscriptWriter, chunks: Sequence[Tuple[float, str, bytes]], t0: float,
                 scale: float) -> None:
    """Write (monotonic time, "hat"|"host"|"note", bytes) chunks as transcript events, in HAT
    milliseconds from ``t0``."""
    for when, kind, data in chunks:
        t = (when - t0) * 1000.0 * scale
        if kind == "hat":
            writer.hat(t, data)
        elif kind == "host":
            writer.host(t, data)
        else:
            writer.flush_partial(t)
            writer.note(t, data.decode(errors="replace"))


def run_plan(plan: Plan, target, meta: dict, ready: Sequence[str] = (),  # type: ignore[no-untyped-def]
             boot_timeout: float = 20.0) -> Tuple[Transcript, float, List[str]]:
    """Run a plan on a target (opened here, closed after). Returns (what crossed the port,
    slack in HAT ms for cutting real-time output, remarks). ``meta.firmware`` is filled in
    from the output's ``version`` answer, or the target's control, when the run shows it."""
    buf = io.StringIO()
    writer = TranscriptWriter(buf, dict(meta, firmware=meta.get("firmware", "unknown")))
    remarks = list(plan.remarks)
    slack = 0.0
    firmware = None
    try:
        if target.has("virtual_time") and hasattr(target, "advance"):
            target.open()
            _replay_virtual(plan, target, writer)
        else:
            late, remark = _replay_realtime(plan, target, writer, ready, boot_timeout)
            slack = late + 20.0
            if remark:
                remarks.append(remark)
            if late > 10.0:
                remarks.append(f"a step went out up to {late:.0f} ms (HAT time) after its recorded time; "
                               "output timed from it shifts by as much")
        firmware = _firmware_of(target)
    finally:
        writer.close()
        try:
            target.close()
        except Exception:  # noqa: BLE001 - closing a dead target must not hide the real error
            pass
    result = read_transcript(io.StringIO(buf.getvalue()))
    for line in result.hat_lines():
        if line.startswith("Firmware version: "):
            firmware = line[len("Firmware version: "):]
            break
    if firmware:
        result.meta["firmware"] = firmware
    return result, slack, remarks


def _firmware_of(target) -> Optional[str]:  # type: ignore[no-untyped-def]
    """The firmware a target with a control says it runs (no traffic on the command port)."""
    emu = getattr(target, "emulator", None)
    hat = getattr(emu, "hat", None)
    if hat is not None and getattr(hat, "version_string", None):
        return str(hat.version_string)
    control = getattr(target, "control", None)
    if control is not None:
        try:
            reply = control.action("@firmware")
        except Exception:  # noqa: BLE001 - a control without @firmware: leave it unknown
            return None
        return reply[3:].strip() if reply.startswith("ok ") else None
    return None


def write_transcript(transcript: Transcript, path: str) -> None:
    """Save a transcript (meta first), e.g. one that :func:`run_plan` returned."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", encoding="utf-8") as fh:
        for obj in [dict({"dir": "meta"}, **{k: v for k, v in transcript.meta.items() if k != "dir"})] \
                + transcript.events:
            fh.write(json.dumps(obj, ensure_ascii=True, separators=(",", ":")) + "\n")


def replay(transcript: Transcript, target, plan: Optional[Plan] = None,  # type: ignore[no-untyped-def]
           out: Optional[str] = None, boot_timeout: float = 20.0) -> Tuple[Transcript, float, List[str]]:
    """Replay a recording on a target; returns (what came back, slack in HAT ms, remarks)."""
    plan = plan or plan_replay(transcript)
    source = transcript.meta.get("name") or transcript.meta.get("script") or ""
    meta = {"target": getattr(target, "url", ""), "tool": "buildhat-conformance replay",
            "version": _tool_version(), "replay_of": source}
    last = _last_line_before_first_host(transcript)
    actual, slack, remarks = run_plan(plan, target, meta, [last] if last else [], boot_timeout)
    if out:
        write_transcript(actual, out)
    return actual, slack, remarks


def _tool_version() -> str:
    from .version import __version__

    return __version__


def _last_line_before_first_host(transcript: Transcript) -> Optional[str]:
    """The last start-up line: the last one before the host first spoke (a session's own
    ``version`` at t < 0 counts, since what answers it is not start-up)."""
    last = None
    for e in transcript.events:
        if e.get("dir") == "host":
            return last
        if e.get("dir") == "hat" and "line" in e and e["line"]:
            last = e["line"]
    return last


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


# -- command line ----------------------------------------------------------------------------
def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("transcript", metavar="FILE", help="the recorded transcript (.jsonl)")
    parser.add_argument("--target", required=True, metavar="URL",
                        help="where to replay: emulator[:N], inprocess[:N], /dev/..., socket://...")
    parser.add_argument("--rule", action="append", default=[], metavar="CLASS=RULE",
                        help="comparison rule per event class: exact | pattern:REGEX | tolerance:N[%%] | "
                             "ignore (repeatable; CLASS 'data' = all data lines, '*' = default)")
    parser.add_argument("--timing-tolerance", type=float, metavar="MS",
                        help="also compare line times, within ±MS HAT milliseconds")
    parser.add_argument("--include-startup", action="store_true",
                        help="compare the start-up output before the first host line too")
    parser.add_argument("--script", metavar="FILE", help="the scenario script that produced the recording "
                        "(default: meta.script)")
    parser.add_argument("--without-world", action="store_true",
                        help="replay the host bytes even though the target cannot perform the world actions")
    parser.add_argument("-o", "--output", metavar="FILE", help="keep what came back as a transcript")
    parser.add_argument("--boot-timeout", type=float, default=20.0, metavar="S",
                        help="real-time targets: wait up to S seconds for the recorded start-up (0: don't)")


def main(args: argparse.Namespace) -> int:
    from .targets import make_target
    from .targets.base import TargetError

    try:
        recorded = read_transcript(args.transcript)
        rules = RuleSet.from_options(args.rule, args.timing_tolerance)
        script = load_script(args.script) if args.script else None
        plan = plan_replay(recorded, args.transcript, script)
    except (OSError, ValueError) as exc:
        print(f"replay: {exc}", file=sys.stderr)
        return 2
    options = {}
    if plan.layout and args.target.split(":", 1)[0].split("?", 1)[0] in ("emulator", "inprocess") \
            and "device=" not in args.target:
        options["devices"] = plan.layout   # the recording's start-up layout, on a target that can take it
    try:
        target = make_target(args.target, **options)
    except TargetError as exc:
        print(f"replay: {exc}", file=sys.stderr)
        return 2
    missing = missing_capabilities(plan, target)
    if missing and not args.without_world:
        print(f"replay: cannot replay {args.transcript} faithfully on {args.target}: the recording's world "
              f"actions need {', '.join('@' + m for m in missing)} (from its {plan.world_source}), "
              "which this target cannot perform. Use a target with a control channel (emulator, "
              "inprocess), or --without-world to send the host bytes alone.", file=sys.stderr)
        return 3
    if missing:
        plan.steps = [s for s in plan.steps if s.kind != "world"]
        plan.remarks.append(f"world actions left out (--without-world): {', '.join(missing)}")
    try:
        actual, slack, remarks = replay(recorded, target, plan, args.output, args.boot_timeout)
    except TargetError as exc:
        print(f"replay: {exc}", file=sys.stderr)
        return 2
    result = compare_transcripts(recorded, actual, rules, include_startup=args.include_startup,
                                 trim_after=plan.end_t + slack if slack else None)
    hosts = [e for e in recorded.events if e.get("dir") == "host"]
    for r in remarks:
        print(f"replay: note: {r}")
    if args.output:
        print(f"replay: what came back is in {args.output}")
    print(f"replay: {args.transcript} on {args.target} (rules: {rules.describe()})")
    print(result.render(hosts))
    return 0 if result.ok else 1
