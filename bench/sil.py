"""The real firmware in the loop (``sil:``), measured through the user's own commands: the suite
in virtual time and at real time, fuzzing throughput, and the firmware coverage the suite and a
campaign reach. The firmware tree is ``$BUILDHAT_FIRMWARE_TREE`` or, on a developer's machine, the
``firmware-pico-*`` tree of the developers' material beside the checkout; without one, the groups say so.
"""
from __future__ import annotations

import os
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Dict, Optional

from .suite import parse_junit
from .throughput import _command, fuzz_command

__all__ = ["firmware_tree", "suite", "fuzz", "coverage"]

_REPO = Path(__file__).resolve().parent.parent


def firmware_tree() -> str:
    given = os.environ.get("BUILDHAT_FIRMWARE_TREE")
    if given:
        return given
    found = sorted((_REPO.parent / "shared" / "firmware").glob("firmware-pico-*"))
    if not found:
        raise RuntimeError("no firmware tree (set BUILDHAT_FIRMWARE_TREE to a firmware-pico/ folder)")
    return str(found[-1])


def _run(target: str, keyword: Optional[str] = None) -> Dict:
    with tempfile.TemporaryDirectory(prefix="bench-sil-") as tmp:
        junit = os.path.join(tmp, "junit.xml")
        argv = _command() + ["run", "--target", target, "--junit", junit]
        argv += ["-k", keyword] if keyword else []
        t0 = time.monotonic()
        subprocess.run(argv, capture_output=True, text=True, timeout=3600)
        wall = time.monotonic() - t0
        if not os.path.exists(junit):
            raise RuntimeError("the suite wrote no JUnit file")
        res = parse_junit(junit)
        cov = os.path.join(tmp, "firmware-coverage.json")
        if os.path.exists(cov):
            import json
            with open(cov, encoding="utf-8") as fh:
                res["coverage"] = json.load(fh)
    res.update(wall_s=wall, note=f"{res['cases']} cases, {res['failed']} failed or faulted, "
                                 f"{res['skipped']} skipped" + (f" (-k {keyword})" if keyword else ""))
    return res


def suite(real_time: bool, keyword: Optional[str] = None) -> Dict:
    """The whole suite against the firmware: in virtual time, or paced at real time."""
    query = "?speed=1" if real_time else ""
    subprocess.run(_command() + ["sil", "build", firmware_tree()], capture_output=True, timeout=600)
    return _run(f"sil:{firmware_tree()}{query}", keyword)


def fuzz(seconds: float) -> Dict:
    """``fuzz --target sil:TREE``, alone, ``--against inprocess`` and ``--against emulator``, as a
    user types them (``--jobs auto``: a worker per usable CPU), and the last with ``--jobs 1`` (one
    worker, what a one-core machine gets): lines/s as each command prints them (one after the
    other: each has the machine)."""
    subprocess.run(_command() + ["sil", "build", firmware_tree()], capture_output=True, timeout=600)
    target = f"sil:{firmware_tree()}"
    res = fuzz_command(target, seconds)
    notes = [f"alone: {res['note']}"] if res.get("note") else []
    for key, extra in (("against_inprocess", ["--against", "inprocess"]),
                       ("against_emulator", ["--against", "emulator"]),
                       ("against_emulator_jobs1", ["--against", "emulator", "--jobs", "1"])):
        # --confirm 0: confirming a (timing) difference would only lengthen the figure's run
        other = fuzz_command(target, seconds, extra=extra + ["--confirm", "0"])
        res[f"{key}_lines_per_s"] = other["lines_per_s"]
        if other.get("note"):
            notes.append(f"{' '.join(extra)}: {other['note']}")
    res["note"] = "; ".join(notes)
    return res


def coverage(fuzz_seconds: float) -> Dict:
    """Firmware line/branch coverage of the whole suite, and of a fuzz campaign alone."""
    tree = firmware_tree()
    res = _run(f"sil:{tree}?coverage=1")
    suite_cov = res.get("coverage") or {}
    fuzz_res = fuzz_command(f"sil:{tree}?coverage=1", fuzz_seconds)
    done = subprocess.run(_command() + ["sil", "coverage", tree], capture_output=True, text=True, timeout=600)
    first = (done.stdout.splitlines() or [""])[0]
    import re
    m = re.search(r"lines ([\d.]+)% .*branches ([\d.]+)%", first)
    return {"suite_line_pct": suite_cov.get("line_percent", float("nan")),
            "suite_branch_pct": suite_cov.get("branch_percent", float("nan")),
            "fuzz_line_pct": float(m.group(1)) if m else float("nan"),
            "fuzz_branch_pct": float(m.group(2)) if m else float("nan"),
            "note": f"fuzz {fuzz_seconds:g} s, {fuzz_res['lines_per_s']:.0f} lines/s"}


def mutation(count: int) -> Dict:
    """``sil mutate --count N --seed 1``: the mutation score its summary line prints."""
    import re
    with tempfile.TemporaryDirectory(prefix="bench-mutate-") as tmp:
        argv = _command() + ["sil", "mutate", firmware_tree(), "--count", str(count), "--seed", "1"]
        argv += ["-o", tmp]
        done = subprocess.run(argv, capture_output=True, text=True, timeout=7200)
    m = re.search(r"mutation score ([\d.]+)% \((\d+) killed by a failing case of (\d+) not likely "
                  r"equivalent\); (\d+) mutants: (.*); (\d+) s", done.stdout)
    if m is None:
        last = (done.stderr.strip().splitlines() or done.stdout.strip().splitlines() or ["no output"])[-1]
        raise RuntimeError(f"sil mutate exited {done.returncode}: {last}")
    return {"score_pct": float(m.group(1)), "seconds": float(m.group(6)), "note": m.group(5)}
