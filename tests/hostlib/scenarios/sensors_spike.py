"""SPIKE sensors: ColorSensor on A, DistanceSensor on B, ForceSensor on C, Matrix on D.

The matrix is plugged in (``PARAMS["plug_matrix"]``) only once the library is listening: it needs motor
power right after it connects, and releases before R4 leave that to the host (DEVICES.md), so a matrix
that connected before any host was there has already given up, as it would on real hardware.

PARAMS["set"][name] are the control lines (``@data ...``) the test wants applied before the library
call ``name``; the test knows what the library must then report.
"""
from __future__ import annotations

import time

from _harness import PARAMS, connect, ctl, ctl_all, emit, run, step, wait_for

SET = PARAMS.get("set", {})


def settle() -> None:
    # A device reports within its data interval (<= 100 ms) after @data; a stale reading may still be
    # in flight, so give the new one time to be the one the library sees.
    time.sleep(0.3)


def given(name: str) -> None:
    ctl_all(SET.get(name))
    settle()


def color(buildhat) -> None:
    c = buildhat.ColorSensor("A")
    given("color.reflected")
    step("color.reflected", c.get_reflected_light)
    given("color.ambient")
    step("color.ambient", c.get_ambient_light)
    given("color.rgbi")
    step("color.rgbi", c.get_color_rgbi)
    step("color.name", c.get_color)
    given("color.hsv")
    step("color.hsv", lambda: list(c.get_color_hsv()))


def distance(buildhat) -> None:
    d = buildhat.DistanceSensor("B")
    given("distance.far")
    step("distance.far", d.get_distance)
    hits = []
    d.when_in_range = lambda dist: hits.append(dist)
    given("distance.near")
    emit("distance.in_range_callback", hits[:1] if wait_for(lambda: bool(hits), 3.0) else None)
    d.when_in_range = None
    if hasattr(d, "eyes"):
        step("distance.eyes", lambda: d.eyes(10, 20, 30, 40))


def force(buildhat) -> None:
    f = buildhat.ForceSensor("C")
    given("force.pressed")
    step("force.force", f.get_force)
    step("force.is_pressed", f.is_pressed)
    if hasattr(f, "get_peak_force"):
        step("force.peak", f.get_peak_force)
    given("force.released")
    step("force.released", f.get_force)
    presses = []
    f.when_pressed = lambda value: presses.append(value)
    given("force.pressed_again")
    emit("force.pressed_callback", presses[:1] if wait_for(lambda: bool(presses), 3.0) else None)
    f.when_pressed = None


def matrix(buildhat, hat) -> None:
    plugged = wait_for(lambda: hat.get()["D"]["typeid"] == 64, 10.0, poll=0.1)
    emit("matrix.connected", plugged)
    m = buildhat.Matrix("D")
    step("matrix.set_pixels", lambda: m.set_pixels([[(3, 10)] * 3, [(6, 5)] * 3, [(9, 1)] * 3]))
    if hasattr(m, "level"):
        step("matrix.level", lambda: m.level(5))
    if hasattr(m, "set_transition"):
        step("matrix.set_transition", lambda: m.set_transition(0))
    step("matrix.clear", m.clear)


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    hat = connect(buildhat)
    ctl(PARAMS["plug_matrix"])   # its LPF2 handshake runs while the other sensors are tested
    color(buildhat)
    distance(buildhat)
    force(buildhat)
    matrix(buildhat, hat)
    time.sleep(0.3)
    emit("lint", ctl("@lint"))


run(main)
