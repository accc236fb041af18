"""The full conformance suite against the emulator: wall time, and how much of it the
protocol made the tests wait.

The suite runs exactly as ``buildhat-conformance run`` runs it (a pytest child process over
the installed ``conformance`` package, the emulator in its own process behind a pty). Every
case writes a ``hat_wait_ms`` JUnit property: the HAT time it spent in waits the protocol
requires (``Session.wait_ms`` / ``collect``, collection windows, and waiting for lines the
HAT prints on its own schedule: device set-up, pulse done ...), see ``Session.note_wait``.
Their sum, divided by the speed, is the run's *mandatory waiting*; everything else in the
wall time (process and emulator start, collection, command round trips, the fences between
cases) is *overhead*.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import tempfile
import time
import xml.etree.ElementTree as ET
from typing import Dict, Optional

# The speed of the scaled run. The emulator must sustain it on a loaded two-core machine
# (ticks are spent in Python): too high and HAT time falls behind the wall clock, the waits
# the tests compute from the time scale become too short, and cases fail.
SCALED_SPEED = 30.0
KEEP = os.path.join("reports", "bench")     # where each run's JUnit file is kept


def parse_junit(path: str) -> Dict:
    """Cases, outcomes and the summed ``hat_wait_ms`` of a conformance JUnit file."""
    root = ET.parse(path).getroot()
    cases = failed = skipped = 0
    wait_ms = case_s = 0.0
    for tc in root.iter("testcase"):
        cases += 1
        case_s += float(tc.get("time") or 0.0)
        if tc.find("failure") is not None or tc.find("error") is not None:
            failed += 1
        elif tc.find("skipped") is not None:
            skipped += 1
        for prop in tc.iter("property"):
            if prop.get("name") == "hat_wait_ms":
                wait_ms += float(prop.get("value") or 0.0)
    return {"cases": cases, "failed": failed, "skipped": skipped, "hat_wait_ms": wait_ms,
            "case_s": case_s}


def suite_run(scaled: bool, speed: float = SCALED_SPEED, keyword: Optional[str] = None,
              target: str = "emulator:latest", keep: Optional[str] = KEEP) -> Dict:
    """One run of the suite; ``scaled``: at ``speed``, else at real time (speed 1). The JUnit
    file is kept in ``keep`` (``suite-speed<N>.xml``: per-case times and waits, to see where
    the overhead is)."""
    from ..conformance.runner import pytest_argv

    speed = speed if scaled else 1.0
    with tempfile.TemporaryDirectory(prefix="bench-suite-") as tmp:
        junit = os.path.join(tmp, "junit.xml")
        args = argparse.Namespace(target=f"{target}?speed={speed:g}", firmware=None, junit=junit,
                                  transcripts=os.path.join(tmp, "transcripts"), keyword=keyword,
                                  operator=False, extra=["-p", "no:randomly"] if _has_randomly() else [])
        t0 = time.monotonic()
        subprocess.call(pytest_argv(args), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall = time.monotonic() - t0
        if not os.path.exists(junit):
            raise RuntimeError("the suite wrote no JUnit file")
        res = parse_junit(junit)
        if keep:
            os.makedirs(keep, exist_ok=True)
            shutil.copyfile(junit, os.path.join(keep, f"suite-speed{speed:g}.xml"))
    waits_s = res["hat_wait_ms"] / 1000.0 / speed
    res.update(wall_s=wall, waits_s=waits_s, speed=speed,
               note=f"{res['cases']} cases, {res['failed']} failed" + (f" (-k {keyword})" if keyword else ""),
               overhead_pct=100.0 * (wall - waits_s) / waits_s if waits_s > 0 else float("nan"))
    return res


def _has_randomly() -> bool:
    import importlib.util

    return importlib.util.find_spec("pytest_randomly") is not None
