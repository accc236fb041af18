"""Motor on A, MotorPair on B+C, PassiveMotor on D. The test judges where the shafts ended.

PARAMS: ``pos`` (a POS value the test turns the shaft of A to with ``@pos``), ``degrees``,
``rotations``, ``target``/``target2`` (run_to_position, the second anticlockwise), ``ramp_speed`` (for
those), ``seconds``/``speed`` (run_for_seconds, start), ``rpm`` (start in rpm units, where the library
has them), ``pair_degrees``.
"""
from __future__ import annotations

import time

from _harness import PARAMS, connect, ctl, emit, run, step


def snapshot(motor, name: str) -> None:
    """POS and APOS through the library, read back to back."""
    emit(name, {"pos": motor.get_position(), "apos": motor.get_aposition()})


def single_motor(buildhat) -> None:
    m = buildhat.Motor("A")
    snapshot(m, "a.initial")

    ctl(f"@pos 0 {PARAMS['pos']}")          # the test turned the shaft by hand
    time.sleep(0.1)
    snapshot(m, "a.after_pos")

    seen = []
    m.when_rotated = lambda speed, pos, apos: seen.append([speed, pos, apos])
    step("a.run_for_degrees", lambda: m.run_for_degrees(PARAMS["degrees"], speed=PARAMS["ramp_speed"]))
    snapshot(m, "a.after_degrees")
    m.when_rotated = None
    emit("a.callbacks", {"count": len(seen), "last": seen[-1] if seen else None})

    step("a.run_for_degrees_reverse",
         lambda: m.run_for_degrees(PARAMS["degrees"], speed=-PARAMS["ramp_speed"]))
    snapshot(m, "a.after_degrees_reverse")

    step("a.run_for_rotations", lambda: m.run_for_rotations(PARAMS["rotations"], speed=PARAMS["ramp_speed"]))
    snapshot(m, "a.after_rotations")

    step("a.run_to_position", lambda: m.run_to_position(PARAMS["target"], speed=PARAMS["ramp_speed"]))
    snapshot(m, "a.after_run_to_position")
    step("a.run_to_position_anticlockwise",
         lambda: m.run_to_position(PARAMS["target2"], speed=PARAMS["ramp_speed"], direction="anticlockwise"))
    snapshot(m, "a.after_anticlockwise")

    before = m.get_position()
    step("a.run_for_seconds", lambda: m.run_for_seconds(PARAMS["seconds"], speed=PARAMS["speed"]))
    emit("a.after_seconds", {"before": before, "after": m.get_position()})

    step("a.start", lambda: m.start(PARAMS["speed"]))
    time.sleep(1.0)                           # the speed PID settles well within a second
    emit("a.running_speed", [m.get_speed() for _ in range(5)])
    step("a.stop", m.stop)
    time.sleep(1.0)
    emit("a.stopped_speed", [m.get_speed() for _ in range(5)])

    if hasattr(m, "set_speed_unit_rpm"):      # 0.6+: speed in rpm runs the R6+ `pid_diff` controller
        m.set_speed_unit_rpm(True)
        step("a.start_rpm", lambda: m.start(PARAMS["rpm"]))
        time.sleep(1.0)                        # let the speed settle, then measure a second of travel
        first = m.get_position()
        time.sleep(1.0)
        emit("a.rpm_travel", m.get_position() - first)
        step("a.stop_rpm", m.stop)
        m.set_speed_unit_rpm(False)


def motor_pair(buildhat) -> None:
    pair = buildhat.MotorPair("B", "C")
    left, right = pair._leftmotor, pair._rightmotor   # the library's own Motor objects, to read back
    emit("pair.before", [left.get_position(), right.get_position()])
    step("pair.run_for_degrees", lambda: pair.run_for_degrees(PARAMS["pair_degrees"], PARAMS["ramp_speed"],
                                                                    -PARAMS["ramp_speed"]))
    emit("pair.after", [left.get_position(), right.get_position()])
    step("pair.start", lambda: pair.start(30, 30))
    time.sleep(0.5)
    step("pair.stop", pair.stop)


def passive_motor(buildhat) -> None:
    p = buildhat.PassiveMotor("D")
    step("passive.start", lambda: p.start(50))
    time.sleep(0.3)
    step("passive.stop", p.stop)


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    connect(buildhat)
    single_motor(buildhat)
    motor_pair(buildhat)
    passive_motor(buildhat)
    time.sleep(0.2)
    emit("lint", ctl("@lint"))


run(main)
