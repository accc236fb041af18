"""The GPIO reset path: the HAT runs another release than the library bundles, so ``Hat()`` pulses RESET
(GPIO 4) through gpiozero, finds the bootloader, uploads its image and waits for the reboot. The runner sets
``GPIOZERO_PIN_FACTORY=buildhat_emulator`` and ``BUILDHAT_EMULATOR_CONTROL``: the pin factory of this project
carries the pulse to the emulator. Then a motor on A, a colour sensor on B, a distance sensor on C and the
light matrix on D through the public API.

PARAMS: ``pos``/``degrees``/``speed`` for the motor, ``set`` (control lines per reading, as in
sensors_spike.py), ``pixels`` (the matrix image).
"""
from __future__ import annotations

import os
import time

from _harness import PARAMS, connect, ctl, ctl_all, emit, run, step

SET = PARAMS.get("set", {})


def given(name: str) -> None:
    ctl_all(SET.get(name))
    time.sleep(0.3)           # a device reports within 100 ms; let the new reading be the one seen


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    emit("pin_factory", os.environ.get("GPIOZERO_PIN_FACTORY"))
    emit("firmware_before", ctl("@firmware"))
    hat = connect(buildhat)                   # reset -> bootloader -> upload -> reboot, all in Hat()
    emit("firmware", ctl("@firmware"))
    step("get", hat.get)

    m = buildhat.Motor("A")
    ctl(f"@pos 0 {PARAMS['pos']}")
    time.sleep(0.1)
    step("a.before", m.get_position)
    step("a.run_for_degrees", lambda: m.run_for_degrees(PARAMS["degrees"], speed=PARAMS["speed"]))
    step("a.after", m.get_position)

    c = buildhat.ColorSensor("B")
    given("color.reflected")
    step("color.reflected", c.get_reflected_light)
    given("color.rgbi")
    step("color.rgbi", c.get_color_rgbi)

    d = buildhat.DistanceSensor("C")
    given("distance")
    step("distance", d.get_distance)

    x = buildhat.Matrix("D")
    before = ctl("@lint")
    step("matrix.set_pixels", lambda: x.set_pixels([[tuple(p) for p in row] for row in PARAMS["pixels"]]))
    step("matrix.clear", x.clear)
    time.sleep(0.3)
    emit("lint_before_matrix", before)
    emit("lint_after_matrix", ctl("@lint"))


run(main)
