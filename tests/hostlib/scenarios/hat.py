"""Hat(device=pty): connect (uploading firmware when the emulator starts in its bootloader), list the
devices, read Vin, drive the LEDs. PARAMS: ``adc`` (raw ADC set before get_vin), ``leds`` (run them)."""
from __future__ import annotations

import time

from _harness import PARAMS, connect, ctl, emit, run, step


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    started = time.monotonic()
    hat = connect(buildhat)
    emit("connect_seconds", round(time.monotonic() - started, 2))
    emit("firmware", ctl("@firmware"))
    step("get", hat.get)
    if "adc" in PARAMS:
        ctl(f"@adc {PARAMS['adc']}")
        time.sleep(0.05)  # the HAT refreshes its Vin reading every millisecond
        if hasattr(hat, "get_vin"):
            step("get_vin", hat.get_vin)
        else:
            emit("get_vin.absent", True)
    if PARAMS.get("leds"):
        if hasattr(hat, "set_leds"):
            before = ctl("@lint")
            step("set_leds", lambda: [hat.set_leds(c) for c in ("orange", "green", "both", "off", "voltage")])
            step("orange_led", lambda: hat.orange_led(True))
            step("green_led", lambda: hat.green_led(True))
            step("green_led_off", lambda: hat.green_led(False))
            time.sleep(0.2)  # let the HAT process the lines before asking the lint
            emit("lint_before_leds", before)
            emit("lint_after_leds", ctl("@lint"))
        else:
            emit("leds.absent", True)


run(main)
