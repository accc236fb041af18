"""python-build-hat's own upstream stress tests, shortened: ``test_continuous_start`` (``Motor.start`` with a
toggled speed in a tight loop) and ``test_continuous_degrees`` (``run_for_degrees`` toggled 0/1), each for
PARAMS["seconds"] instead of five minutes. A real HAT takes both; the test checks the lint agrees. Records
the loop's calls, the host lines the emulator counted for it and the seconds it ran.
"""
from __future__ import annotations

import json
import time

from _harness import PARAMS, connect, ctl, emit, run


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    connect(buildhat)
    m = buildhat.Motor("A")
    for name, call in (("continuous_start", m.start), ("continuous_degrees", m.run_for_degrees)):
        before = json.loads(ctl("@lint"))["lines"]
        started = time.monotonic()
        toggle = calls = 0
        while time.monotonic() < started + PARAMS["seconds"]:
            call(toggle)
            toggle ^= 1
            calls += 1
        seconds = time.monotonic() - started
        lines = json.loads(ctl("@lint"))["lines"] - before
        emit(name, {"calls": calls, "lines": lines, "seconds": round(seconds, 3)})
    m.stop()


run(main)
