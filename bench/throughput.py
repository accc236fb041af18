"""Fuzz throughput, as the user gets it: ``buildhat-conformance fuzz`` run as a command, and the
figures it prints in its own summary (lines/s; over a wire, the share of 115200 baud used in the
busier direction). Nothing here has a path of its own: what is timed is the whole campaign
(generation, the model, every oracle, confirming findings excluded as the command reports).

The targets are the three of issue 15: the emulator in the command's own process (virtual time),
the emulator as its own process over a pty (real time, no pacing), and the emulator paced to
115200 baud over a pty (a real HAT's wire).
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from typing import Dict, List, Optional, Sequence

__all__ = ["fuzz_command", "parse_summary", "inprocess", "over_pty", "baud_paced", "parallel_ptys",
           "PTY_URL", "PACED_URL"]

PTY_URL = "emulator:latest?speed=1"
PACED_URL = "emulator:latest?speed=1&baud=115200"

_RATE = re.compile(r"^fuzz: (\d+) runs, (\d+) inputs \((\d+) lines, (\d+) lines/s\) in ([\d.]+) s", re.M)
_CPU = re.compile(r"(?:this process|\d+ workers): ([\d.]+) s of CPU, (\d+) lines per CPU second", re.M)
_WIRE = re.compile(r"wire: sent (\d+) B/s, received (\d+) B/s; the busier direction carries (\d+) %", re.M)
_FINDING = re.compile(r"^  FINDING \[(\w+)\]", re.M)


def _command() -> List[str]:
    """The installed ``buildhat-conformance`` next to this interpreter (else the module)."""
    exe = os.path.join(os.path.dirname(sys.executable), "buildhat-conformance")
    return [exe] if os.path.exists(exe) else [sys.executable, "-m", "buildhat_conformance.cli"]


def parse_summary(text: str) -> Dict:
    """The figures of a ``fuzz`` summary: runs, inputs, lines, lines_per_s, seconds, and over a
    wire sent/recv bytes/s and wire_share_pct; findings lists the oracles of its findings."""
    m = _RATE.search(text)
    if m is None:
        raise ValueError("no summary line in the fuzz command's output")
    res: Dict = {"runs": int(m.group(1)), "inputs": int(m.group(2)), "lines": int(m.group(3)),
                 "lines_per_s": float(m.group(4)), "seconds": float(m.group(5)),
                 "findings": _FINDING.findall(text)}
    c = _CPU.search(text)
    if c is not None:
        res.update(cpu_s=float(c.group(1)), lines_per_cpu_s=float(c.group(2)))
    w = _WIRE.search(text)
    if w is not None:
        res.update(sent_bytes_per_s=float(w.group(1)), recv_bytes_per_s=float(w.group(2)),
                   wire_share_pct=float(w.group(3)))
    return res


def fuzz_command(target: str, seconds: float, seed: int = 1, extra: Sequence[str] = ()) -> Dict:
    """Run ``buildhat-conformance fuzz --target TARGET --budget <seconds>s`` and read its summary."""
    with tempfile.TemporaryDirectory(prefix="bench-fuzz-") as out:
        argv = _command() + ["fuzz", "--target", target, "--budget", f"{seconds:g}s", "--seed", str(seed),
                             "--no-database", "--quiet", "--out", out, *extra]
        proc = subprocess.run(argv, capture_output=True, text=True, timeout=seconds * 4 + 120)
    if proc.returncode not in (0, 1):
        last = (proc.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise RuntimeError(f"fuzz exited {proc.returncode}: {last}")
    res = parse_summary(proc.stdout)
    n = len(res["findings"])
    res["note"] = f"{n} finding(s): {', '.join(res['findings'])}" if n else ""
    return res


def inprocess(seconds: float = 10.0) -> Dict:
    """The emulator in the command's own process, in virtual time."""
    return fuzz_command("inprocess", seconds)


def over_pty(seconds: float = 10.0) -> Dict:
    """The emulator as its own process at real time, through a pty (no baud pacing)."""
    return fuzz_command(PTY_URL, seconds)


def baud_paced(seconds: float = 10.0, url: Optional[str] = None) -> Dict:
    """The emulator paced to 115200 baud over a pty: lines/s and the wire share the command prints."""
    return fuzz_command(url or PACED_URL, seconds)


def parallel_ptys(n: int = 3, seconds: float = 10.0) -> Dict:
    """``n`` fuzz commands at once, each with its own emulator over its own pty: lines/s summed
    (``--jobs 1`` each: ``n`` campaigns, not ``n`` times a worker per CPU)."""
    with ThreadPoolExecutor(max_workers=n) as pool:
        results = list(pool.map(lambda i: fuzz_command(PTY_URL, seconds, seed=i, extra=["--jobs", "1"]),
                                range(1, n + 1)))
    found = sum(len(r["findings"]) for r in results)
    return {"lines_per_s": sum(r["lines_per_s"] for r in results), "targets": n,
            "per_target": [r["lines_per_s"] for r in results],
            "note": f"{n} emulators" + (f", {found} finding(s)" if found else "")}
