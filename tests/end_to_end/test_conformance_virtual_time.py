"""The whole suite in virtual time (``--target inprocess``) gives, case for case, the verdicts of a
run that follows the wall clock (the same emulator over a real pty, paced by real time).

Both runs go at once: the pty run mostly waits on its clock, the in-process one mostly computes.
This is also the test that keeps the pty path of the whole suite covered by ``make test``.
"""
from __future__ import annotations

import os
import tempfile
from concurrent.futures import ThreadPoolExecutor
from typing import Dict, Tuple

import pytest
from mutants.suite_run import CaseResult, run_suite

pytestmark = pytest.mark.timeout(600)

# The wall-clock run: the default `emulator` target's own speed-up (10x), which the suite
# already measures in HAT time. Virtual time must not change a single verdict.
WALL_CLOCK = "emulator:latest?speed=10"
VIRTUAL = "inprocess:latest"


# A loaded machine can starve the wall-clock run (its clock goes on while it is not scheduled), so a
# case whose verdicts differ is run again on the wall clock at a gentler speed-up before the two are
# compared: a case that differs then as well is a real difference between the two clocks.
RECHECK = "emulator:latest?speed=2"


# Nothing is exempt: what only a world shows (the motor drive, `drive_events`) comes over the
# emulator's control channel too (`@drive_events`), so those cases run on both sides.
def _differences(wall: Dict[str, CaseResult], virtual: Dict[str, CaseResult]) -> Dict[str, Tuple[str, str]]:
    return {name: (wall[name].verdict, virtual[name].verdict)
            for name in wall if name in virtual and wall[name].verdict != virtual[name].verdict}


def _first_line(result: CaseResult) -> str:
    return result.message.splitlines()[0] if result.message else ""


def test_virtual_time_verdicts_equal_the_wall_clock_run() -> None:
    with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
        with ThreadPoolExecutor(max_workers=2) as pool:
            wall = pool.submit(run_suite, a, WALL_CLOCK, timeout=540)
            virtual = pool.submit(run_suite, b, VIRTUAL, timeout=540)
            wall_results, virtual_results = wall.result(), virtual.result()
        # A sanity floor: both ran the suite (it has several hundred cases), not an empty selection.
        assert len(wall_results) > 300, os.listdir(a)
        assert set(virtual_results) == set(wall_results)
        differ = _differences(wall_results, virtual_results)
        if differ:
            functions = sorted({name.split("[")[0] for name in differ})
            with tempfile.TemporaryDirectory() as c:
                again = run_suite(c, RECHECK, keyword=" or ".join(functions), timeout=300)
            wall_results = dict(wall_results, **{n: r for n, r in again.items() if n in differ})
            differ = _differences(wall_results, virtual_results)
        assert not differ, "verdicts (wall clock, virtual time) differ: " + "; ".join(
            f"{n}: {w} vs {v} ({_first_line(virtual_results[n])}{_first_line(wall_results[n])})"
            for n, (w, v) in sorted(differ.items()))
        failed = [n for n, r in virtual_results.items() if r.verdict == "fail"]
        assert not failed, f"the virtual-time run failed: {failed}"
