"""A host that writes faster than the wire: python-build-hat's ``Motor.start`` in a tight loop (its upstream
``test_continuous_start``, shortened to PARAMS["seconds"]), then ``Hat.get_vin()``, timed on the host's clock.

On a real HAT the host's writes block once the UART and its driver's buffer are full, so the loop runs at
the wire's pace and the ``vin`` after it waits only for what those buffers still hold (issue 39). Records
the loop's calls and seconds, the bytes it wrote, the host-lint summary before and after, and how long
``get_vin`` took.
"""
from __future__ import annotations

import json
import time

from _harness import PARAMS, connect, ctl, emit, run


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    hat = connect(buildhat)
    m = buildhat.Motor("A")
    before = json.loads(ctl("@lint"))
    started = time.monotonic()
    toggle = calls = 0
    while time.monotonic() < started + PARAMS["seconds"]:
        m.start(toggle)
        toggle ^= 1
        calls += 1
    emit("loop", {"calls": calls, "seconds": round(time.monotonic() - started, 3)})
    asked = time.monotonic()
    vin = hat.get_vin()
    emit("get_vin", {"volts": vin, "seconds": round(time.monotonic() - asked, 3)})
    m.stop()
    emit("lint", {"before": before, "after": json.loads(ctl("@lint"))})


run(main)
