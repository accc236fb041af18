"""BOOST/WeDo/passive devices: ColorDistanceSensor on A, Light (passive 8) on B, WeDo TiltSensor on C,
WeDo MotionSensor on D. PARAMS["set"][name]: control lines applied before the library call ``name``;
PARAMS["unplug"]: the action that pulls the tilt sensor out at the end."""
from __future__ import annotations

import time

from _harness import PARAMS, connect, ctl, ctl_all, emit, run, step, wait_for

SET = PARAMS.get("set", {})


def given(name: str) -> None:
    ctl_all(SET.get(name))
    time.sleep(0.3)   # let the new reading be the one in flight (devices report within 100 ms)


def color_distance(buildhat) -> None:
    cd = buildhat.ColorDistanceSensor("A")
    given("cd.reflected")
    step("cd.reflected", cd.get_reflected_light)
    given("cd.ambient")
    step("cd.ambient", cd.get_ambient_light)
    given("cd.rgb")
    step("cd.rgb", cd.get_color_rgb)
    step("cd.name", cd.get_color)
    if hasattr(cd, "get_distance"):
        given("cd.distance")
        step("cd.distance", cd.get_distance)


def light(buildhat) -> None:
    lamp = buildhat.Light("B")
    if hasattr(lamp, "brightness"):
        step("light.brightness", lambda: lamp.brightness(50))
    else:
        step("light.on", lamp.on)
    time.sleep(0.2)
    step("light.off", lamp.off)


def wedo(buildhat, hat) -> None:
    tilt = buildhat.TiltSensor("C")
    given("tilt")
    step("tilt", lambda: list(tilt.get_tilt()))
    motion = buildhat.MotionSensor("D")
    given("motion.distance")
    step("motion.distance", motion.get_distance)
    if hasattr(motion, "get_movement_count"):
        given("motion.count")
        step("motion.count", motion.get_movement_count)

    ctl(PARAMS["unplug"])
    gone = wait_for(lambda: not hat.get()["C"]["connected"], 3.0)
    emit("unplug.noticed", gone)
    if gone:   # a library that missed the unplug would wait forever for data in get()
        step("unplug.get_tilt", tilt.get_tilt)


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    hat = connect(buildhat)
    color_distance(buildhat)
    light(buildhat)
    wedo(buildhat, hat)
    time.sleep(0.3)
    emit("lint", ctl("@lint"))


run(main)
