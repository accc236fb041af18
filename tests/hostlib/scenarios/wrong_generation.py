"""A library on a HAT of the other protocol generation, which reports the version the library expects
(``--version-string``), so the library does not upload and talks its own dialect to the wrong release.
Nothing here waits for a motor (its ``pid``/``set ramp`` line fails on such a release, so no
``ramp done`` would ever come); the test reads the host lint."""
from __future__ import annotations

import time

from _harness import connect, ctl, emit, run, step


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    connect(buildhat)
    motor = buildhat.Motor("A")
    step("position", motor.get_position)
    step("run_for_degrees", lambda: motor.run_for_degrees(90, speed=25, blocking=False))
    time.sleep(1.0)
    emit("lint", ctl("@lint"))


run(main)
