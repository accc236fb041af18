"""Appendix A, run as written (with `port 0` replaced by the port the device is on).

Each example states what a person would see; these checks look for it on the wire: the
motor's own reports, the sensors' data lines, and no `Error`.
"""
from __future__ import annotations

import re
from typing import List

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import accepted
from ..needs import PortNeeds
from ..probes import data_lines, pid_lines
from ..verdict import Verdict

INT = r"(?: 0|[+-][1-9][0-9]*)"


def values(lines: List[str], head: str) -> List[List[int]]:
    out = []
    for ln in lines:
        m = re.fullmatch(rf"{re.escape(head)}:((?: {INT})+)", ln)
        if m:
            out.append([int(v) for v in m.group(1).replace(" 0", " +0").split()])
    return out


def run_lines(hat: HatUnderTest, lines: List[str]) -> List:
    return [hat.exchange(line) for line in lines]


@pytest.mark.req("EX-MOTOR-TRIANGLE", "CMD-SET-TRIANGLE")
def test_motor_triangle(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    hat.exchange(f"port {p} ; select 1")
    mark = hat.mark()
    replies = run_lines(hat, [f"port {p}", "plimit 1", "set triangle 0 1 10 0"])
    for reply in replies:
        accepted(reply, "the document's example")
    start = len(hat.since(mark))
    # SPEED is reported every 100 ms of HAT time (docs/FIRMWARE-BEHAVIOUR.md#fb-reporting): 100
    # reports are the 10 s period, counted on the HAT's clock rather than the wall's.
    hat.wait_for(lambda e: e.text.startswith(f"P{p}M1:"), 100, 30000)
    events = hat.since(mark)[start:]
    hat.exchange("select ; set 0 ; plimit 0.1")
    speeds = [v[0] for v in values(data_lines(events, p), f"P{p}M1")][:100]
    assert len(speeds) >= 90, f"{len(speeds)} SPEED reports"
    means = [sum(speeds[i:i + 10]) / len(speeds[i:i + 10]) for i in range(0, len(speeds), 10)]
    peak = max(range(len(means)), key=lambda i: means[i])
    # Speeds up to the middle of the 10 s period, then slows down again.
    assert 3 <= peak <= 6 and means[peak] > 30, f"SPEED per second {means}"
    assert means[0] < means[peak] - 20 and means[-1] < means[peak] - 20, f"SPEED per second {means}"


@pytest.mark.req("EX-MOTOR-PID", "CMD-COMBI")
def test_motor_position_pid(hat: HatUnderTest, verdict: Verdict, motor_port: int) -> None:
    p = motor_port
    replies = run_lines(hat, [f"port {p} combi 0 1 0 2 0 3 0", "select 0", "plimit 1; bias .4",
                              f"pid {p} 0 5 s2 0.0027777778 1 5 0 .1 3", "debug 16", "set square 0 1 3 0"])
    mark = hat.mark()
    # Combi reports come every 100 ms of HAT time: 65 of them are two square periods.
    hat.wait_for(lambda e: e.text.startswith(f"P{p}C0:"), 65, 20000)
    events = hat.since(mark)
    hat.exchange("debug 0 ; select ; pwm ; set 0 ; plimit 0.1 ; combi 0")
    if hat.has("bias"):
        hat.exchange("bias 0")
    pos = [v[1] for v in values(data_lines(events, p), f"P{p}C0")]
    assert len(pos) >= 20, f"only {len(pos)} combi reports in 6.5 s"
    rises = max(b - min(pos[:i + 1]) for i, b in enumerate(pos))
    falls = max(max(pos[:i + 1]) - b for i, b in enumerate(pos))
    errors = [r.raw for r in replies if r.errors]
    pid_on = bool(pid_lines(events, p))
    # One revolution each way: the position goes up by about 360 degrees and back down.
    doc_ok = not errors and pid_on and rises >= 270 and falls >= 270
    fw_ok = len(errors) == 2 and not pid_on and falls < 90
    verdict.document(doc_ok, key="EX-MOTOR-PID-NEEDS-DEADZONE", firmware_ok=fw_ok,
                     seen=f"errors {errors}, PID {'on' if pid_on else 'off'}, "
                          f"position rose {rises} fell {falls}")


@pytest.mark.req("EX-COLOUR", "ID-ACTIVE")
def test_colour_sensor(hat: HatUnderTest, world: PortNeeds) -> None:
    p = world.active(0x3D)
    replies = run_lines(hat, [f"port {p} ; plimit 1 ; set -1 ; select 0"])
    got = values(data_lines(hat.wait_for(lambda e: e.text.startswith(f"P{p}M0:"), 3, 1500), p), f"P{p}M0")
    hat.exchange("select ; set 0")
    assert replies[0].errors == 0 and got, "no colour reports"
    assert all(v[0] in (-1, 0, 1, 3, 4, 5, 7, 9, 10) for v in got), f"colours {got} (devices.json M0)"


@pytest.mark.req("EX-DISTANCE", "ID-ACTIVE")
def test_distance_sensor(hat: HatUnderTest, world: PortNeeds) -> None:
    p = world.active(0x3E)
    replies = run_lines(hat, [f"port {p} ; plimit 1 ; set -1 ; select 1"])
    got = values(data_lines(hat.wait_for(lambda e: e.text.startswith(f"P{p}M1:"), 3, 1500), p), f"P{p}M1")
    hat.exchange("select ; set 0")
    assert replies[0].errors == 0 and got, "no distance reports"
    assert all(v[0] == -1 or 0 <= v[0] <= 2500 for v in got), f"distances {got} (mm, -1 = no echo)"


@pytest.mark.req("EX-DISTANCE-LEDS")
def test_distance_sensor_leds(hat: HatUnderTest, world: PortNeeds) -> None:
    p = world.active(0x3E)
    replies = run_lines(hat, [f"port {p} ; plimit 1 ; set -1", "select 5 ; write1 c5 64 00 32 0a"])
    hat.exchange("select ; set 0")
    for reply in replies:
        accepted(reply, "the document's example")


@pytest.mark.req("EX-FORCE", "ID-ACTIVE")
def test_force_sensor(hat: HatUnderTest, world: PortNeeds) -> None:
    p = world.active(0x3F)
    replies = run_lines(hat, [f"port {p} ; select 0"])
    got = values(data_lines(hat.wait_for(lambda e: e.text.startswith(f"P{p}M0:"), 3, 1500), p), f"P{p}M0")
    hat.exchange("select")
    assert replies[0].errors == 0 and got and all(0 <= v[0] <= 100 for v in got), f"forces {got}"


@pytest.mark.req("EX-MATRIX-POWER", "EX-MATRIX-MODES", "ID-ACTIVE")
def test_light_matrix(hat: HatUnderTest, world: PortNeeds) -> None:
    p = world.active(0x40)
    mark = hat.mark()
    lines = [f"port {p} ; plimit 1 ; set -1", "select 0 ; write1 c0 5", "select 1 ; write1 c1 0a",
             "select 2 ; write1 c2 12 23 34 45 12 23 34 45 12", "write1 c2 67 72 78 82 89 92 9a a4 aa",
             "write1 c2 1a 2a 3a 4a 5a 6a 7a 8a 9a", "write1 c2 a1 a2 a3 a4 a5 a6 a7 a8 a9",
             "select 3 ; write1 c3 1", "write1 c3 2"]
    replies = run_lines(hat, lines)
    hat.wait_ms(2000)
    texts = [e.text for e in hat.since(mark)]
    hat.exchange("select")
    assert all(r.errors == 0 for r in replies), [r.raw for r in replies if r.errors]
    assert not any(re.match(rf"P{p}: (timeout|disconnected)", t) for t in texts), \
        "the powered matrix went away"
    assert world.find(("active", 0x40)) == p, f"the light matrix must still be on port {p}"


@pytest.mark.req("EX-MATRIX-POWER", "FW-MATRIX-AUTOPOWER")
def test_light_matrix_without_host_power(hat: HatUnderTest, world: PortNeeds, verdict: Verdict,
                                         empty_port: int) -> None:
    world.require("plug", "plugging the light matrix in")
    p = empty_port
    mark = hat.mark()
    world.plug_only(p, ("active", 0x40))
    hat.expect(lambda e: e.text == f"P{p}: established serial communication with active ID 40", 6000)
    hat.wait_ms(3000)
    texts = [e.text for e in hat.since(mark)]
    lost = any(re.match(rf"P{p}: (timeout|disconnected)", t) for t in texts)
    if hat.feature("matrix_autopower"):
        assert not lost, "R4/R6/R7 power the matrix themselves when it is established " \
                         "(docs/FIRMWARE-BEHAVIOUR.md#fb-led-matrix)"
    else:
        verdict.inform("without auto-power the matrix " + ("disconnected" if lost else "stayed") +
                       " within 3 s; how soon a real matrix gives up is the device's behaviour")
