"""Faulty HATs through the user's own commands: how long a run takes to give up on a dead
target, and how much memory the harness needs while a HAT floods the link.

The faulty HATs are the repository's ``tests/faulty/faulty_hat.py`` (``buildhat-emulator
--stdio`` behind a link fault) as ``cmd:`` targets; from a wheel without the repository these
figures are blank and say why.

- *Declaring a dead target*: ``buildhat-conformance run`` on a HAT that goes silent (or stops
  reading its input) mid-run; the time from the start of the first case that met the fault to
  the run no longer talking to the target (``--max-target-faults``, default 5 in a row). Read
  from the run's JUnit file (per-case times).
- *A hung HAT reset*: ``buildhat-conformance run`` on the emulator with its hung-firmware fault;
  the time from the first case that met the hang to the first case that passed again after the
  run's one reset (conformance/plugin/recovery.py).
- *Memory under a flood*: ``buildhat-conformance script`` waiting while the HAT floods 3,000
  lines/s; the harness process's peak resident memory (VmHWM), and whether the transcript on
  disk holds every flooded line. The issue's figure is a 10-minute flood (< 150 MB); ``make
  bench`` floods for FLOOD_SECONDS to keep the whole bench short.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from typing import Dict, List, Optional

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FAULTY = os.path.join(REPO, "tests", "faulty", "faulty_hat.py")
FLOOD_SECONDS = 60.0
EMULATOR = ["--", "--booted", "--speed", "20"]
_FLOOD_NUMBER = re.compile(r"FLOOD (\d+) the quick")


def _command(name: str) -> List[str]:
    exe = os.path.join(os.path.dirname(sys.executable), name)
    return [exe] if os.path.exists(exe) else [name]


def _faulty(args: List[str]) -> str:
    if not os.path.exists(FAULTY):
        raise RuntimeError("needs the repository's tests/faulty/faulty_hat.py")
    return "cmd:" + " ".join([sys.executable, FAULTY, *args])


def dead_target(kind: str = "silent") -> Dict:
    """Seconds from the first case that met a ``kind`` fault (``silent``, ``deaf``) to the run
    giving up on the target, through ``buildhat-conformance run``."""
    target = _faulty([kind, "--after", "0", "--on", "vin", *EMULATOR])
    with tempfile.TemporaryDirectory(prefix="bench-dead-") as tmp:
        junit = os.path.join(tmp, "junit.xml")
        t0 = time.monotonic()
        subprocess.run([*_command("buildhat-conformance"), "run", "--target", target, "-k", "test_link",
                        "--junit", junit], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       timeout=600, cwd=tmp)
        wall = time.monotonic() - t0
        faults: List[float] = []
        not_run = 0
        for case in ET.parse(junit).getroot().iter("testcase"):
            verdict = {p.get("name"): p.get("value") for p in case.iter("property")}.get("verdict")
            if verdict == "target-fault":
                faults.append(float(case.get("time") or 0.0))
            elif verdict == "not-run":
                not_run += 1
    if not faults:
        raise RuntimeError(f"the {kind} HAT caused no target fault")
    return {"declare_s": sum(faults), "faults": len(faults), "wall_s": wall,
            "note": f"{len(faults)} target faults, then {not_run} cases not run; run {wall:.0f} s"}


def hung_and_reset(hang_after: int = 60) -> Dict:
    """Seconds from the first case that met a hung HAT (the emulator's ``?hang_after=N`` fault,
    at real time) to the end of the first case that passed again after the run's one reset."""
    target = f"emulator:?hang_after={hang_after}&speed=1"
    with tempfile.TemporaryDirectory(prefix="bench-hang-") as tmp:
        junit = os.path.join(tmp, "junit.xml")
        subprocess.run([*_command("buildhat-conformance"), "run", "--target", target,
                        "-k", "test_abbreviation", "--junit", junit],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=600, cwd=tmp)
        root = ET.parse(junit).getroot()
        props = {p.get("name"): p.get("value") for p in root.iter("property")}
        spent, faults, back = 0.0, 0, False
        for case in root.iter("testcase"):
            verdict = {p.get("name"): p.get("value") for p in case.iter("property")}.get("verdict")
            if verdict == "target-fault":
                faults += 1
            if faults:
                spent += float(case.get("time") or 0.0)
                if verdict != "target-fault":
                    back = True
                    break
    if not faults or not back:
        raise RuntimeError(f"no recovery: {faults} target faults; "
                           f"{props.get('stopped') or props.get('reset') or 'the hang came too late'}")
    outcome = (props.get("reset") or "").split(" (after ")[0]
    return {"recover_s": spent, "note": f"{faults} target faults, then {outcome}"}


def _peak_rss_kib(pid: int) -> Optional[int]:
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def flood_memory(seconds: float = FLOOD_SECONDS) -> Dict:
    """Peak RSS of ``buildhat-conformance script`` while the HAT floods 3,000 lines/s for
    ``seconds``, and the share of the flooded lines its transcript holds."""
    with tempfile.TemporaryDirectory(prefix="bench-flood-") as tmp:
        log, script = os.path.join(tmp, "fired.log"), os.path.join(tmp, "flood.script")
        transcript = os.path.join(tmp, "flood.jsonl")
        with open(script, "w", encoding="utf-8") as fh:
            fh.write(f";; listen while the HAT floods\n> vin\n@wait {int((seconds + 2) * 1000)}\n")
        target = _faulty(["flood", "--on", "vin", "--after", "0", "--flood-seconds", f"{seconds:g}",
                          "--log", log, *EMULATOR])
        argv = [*_command("buildhat-conformance"), "script", script, "--target", target, "-o", transcript]
        proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=tmp)
        peak = 0
        while proc.poll() is None:
            peak = max(peak, _peak_rss_kib(proc.pid) or 0)
            time.sleep(0.5)
        err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
        flooded = 0
        if os.path.exists(log):
            for line in open(log, encoding="utf-8"):
                if line.startswith("flood ended after "):
                    flooded = int(line.split()[3])
        # The flood's lines are numbered: the transcript is complete when it holds every number
        # up to the last the HAT sent (the log's count; the highest seen if the HAT was stopped
        # before it could log, e.g. when the harness could not keep up and the script ended).
        # The HAT's byte stream is every `partial` and every `line` + CRLF in order (TRANSCRIPT.md):
        # a line that waited for its end is a partial and then a line, and a flood line can share
        # a line with the HAT's own output, so numbers are looked for in that stream.
        seen = set()
        if os.path.exists(transcript):
            with open(transcript, encoding="utf-8") as fh:
                carry = ""
                for text in fh:
                    if '"dir":"hat"' not in text:
                        continue
                    event = json.loads(text)
                    if "partial" in event:
                        carry += event["partial"]
                    elif "line" in event:
                        seen.update(int(n) for n in _FLOOD_NUMBER.findall(carry + event["line"]))
                        carry = ""
        kept = len(seen)
        flooded = flooded or (max(seen) + 1 if seen else 0)
        if not flooded:
            raise RuntimeError(f"the flood did not run (script: {err.strip()[-200:]})")
        if os.environ.get("BENCH_KEEP_FLOOD"):
            shutil.copyfile(transcript, os.environ["BENCH_KEEP_FLOOD"])
    return {"rss_mib": peak / 1024.0, "kept_pct": 100.0 * kept / flooded,
            "note": f"{seconds:g} s flood, {flooded:,} lines; the issue's 10 min: flood_memory(600)"}
