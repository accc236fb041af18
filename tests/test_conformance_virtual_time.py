"""The whole suite in virtual time (``--target inprocess``) gives, case for case, the verdicts of a
run that follows the wall clock (the same emulator over a real pty, paced by real time).

Both runs go at once: the pty run mostly waits on its clock, the in-process one mostly computes.
This is also the test that keeps the pty path of the whole suite covered by ``make test``.
"""
from __future__ import annotations

import os
import tempfile
from concurrent.futures import ThreadPoolExecutor

import pytest

from .mutants.suite_run import run_suite

pytestmark = pytest.mark.timeout(600)

# The wall-clock run: the default `emulator` target's own speed-up (10x), which the suite
# already measures in HAT time. Virtual time must not change a single verdict.
WALL_CLOCK = "emulator:latest?speed=10"
VIRTUAL = "inprocess:latest"


def test_virtual_time_verdicts_equal_the_wall_clock_run() -> None:
    with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
        with ThreadPoolExecutor(max_workers=2) as pool:
            wall = pool.submit(run_suite, a, WALL_CLOCK, timeout=540)
            virtual = pool.submit(run_suite, b, VIRTUAL, timeout=540)
            wall_results, virtual_results = wall.result(), virtual.result()
        # A sanity floor: both ran the suite (it has several hundred cases), not an empty selection.
        assert len(wall_results) > 300, os.listdir(a)
        assert set(virtual_results) == set(wall_results)
        differ = {name: (wall_results[name].verdict, virtual_results[name].verdict)
                  for name in wall_results if wall_results[name].verdict != virtual_results[name].verdict}
        assert not differ, "verdicts (wall clock, virtual time) differ: " + "; ".join(
            f"{n}: {w} vs {v} ({virtual_results[n].message.splitlines()[0] if virtual_results[n].message else ''}"
            f"{wall_results[n].message.splitlines()[0] if wall_results[n].message else ''})"
            for n, (w, v) in sorted(differ.items()))
        failed = [n for n, r in virtual_results.items() if r.verdict == "fail"]
        assert not failed, f"the virtual-time run failed: {failed}"
