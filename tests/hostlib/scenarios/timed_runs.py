"""python-build-hat's ``Motor.run_for_seconds(N)``, timed on the host's clock (issue 27).

The library sends one line ending in ``set pulse <speed> 0.0 N 0`` and returns when the HAT's
``P0: pulse done`` arrives; its own hardware test (``test_time``) checks that 5 s take 5 s. Records
how long each call of PARAMS["seconds"] took, measured around the call as that test does.
"""
from __future__ import annotations

import time

from _harness import PARAMS, connect, emit, run


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    connect(buildhat)
    m = buildhat.Motor("A")
    for seconds in PARAMS["seconds"]:
        started = time.monotonic()
        m.run_for_seconds(seconds)
        emit(f"run_for_seconds.{seconds}", round(time.monotonic() - started, 4))


run(main)
