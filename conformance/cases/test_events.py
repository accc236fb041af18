"""EVT-CONNECT / EVT-DISCONNECT: what plugging and unplugging prints
(docs/FIRMWARE-BEHAVIOUR.md#fb-passive, #fb-active)."""
from __future__ import annotations

import re

import pytest

from ...protocol.devices import catalogue
from ..hat_under_test import HatUnderTest
from ..needs import PortNeeds
from ..oracles.listing import render_active
from ..probes import MOTOR, TickClock
from ..verdict import Verdict

SENSOR = 0x3E       # the ultrasonic sensor: an active device the default layout does not have
# Lines from other ports that may come in between the connect messages.
ASYNC = re.compile(r"P[0-3][MCV]|deltat=|P[0-3]: connected to passive")


def _texts(events: list) -> list:
    return [e.text for e in events]


@pytest.mark.req("EVT-CONNECT", "CMD-LIST-ACTIVE")
def test_active_device_connect_messages(hat: HatUnderTest, world: PortNeeds, empty_port: int) -> None:
    world.require("plug", "plugging a device in")
    p = empty_port
    mark = hat.mark()
    world.plug_only(p, ("active", SENSOR))
    done = f"P{p}: established serial communication with active ID 3E"
    hat.expect(lambda e: e.text == done, 6000)
    texts = [t for t in _texts(hat.since(mark)) if not ASYNC.match(t)]
    start = texts.index(f"P{p}: connecting to active device")
    block = render_active(p, catalogue()[f"0x{SENSOR:02X}"])
    expected = ["set baud rate to 115200"] + block + [done]
    got = texts[start + 1:start + 1 + len(expected)]
    differs = next(((a, b) for a, b in zip(expected, got) if a != b), (done, got[-1:]))
    assert got == expected, (f"after `connecting to active device`: expected {len(expected)} lines ending "
                             f"{done!r}; first difference: expected {differs[0]!r}, came {differs[1]!r}")


@pytest.mark.req("EVT-CONNECT")
def test_passive_device_connect_message(hat: HatUnderTest, world: PortNeeds, verdict: Verdict,
                                        empty_port: int) -> None:
    world.require("plug", "plugging a device in")
    p = empty_port
    mark = hat.mark()
    world.plug_only(p, ("passive", 1))
    hat.expect(lambda e: e.text == f"P{p}: connected to passive ID 1", 3000)
    hat.wait_ms(1500)
    texts = _texts(hat.since(mark))
    n = texts.count(f"P{p}: connected to passive ID 1")
    assert n >= 1, "no 'connected' message"
    verdict.document(n == 1, key="PASSIVE-CONNECT-REPEATS", firmware_ok=n >= 3,
                     seen=f"{n} 'connected to passive ID 1' lines in 1.5 s")


@pytest.mark.req("EVT-CONNECT", "EVT-DISCONNECT")
def test_passive_device_swapped_for_another_connects_after_six_scans(hat: HatUnderTest, world: PortNeeds,
                                                                     motor_port: int) -> None:
    # FIRMWARE-BEHAVIOUR#fb-passive: another ID on a connected port is `disconnected`, and the new
    # device is `connected` once six scans in a row read its ID, as at a first plug-in: not at
    # the next scan, as if the count of the device before went on. Timed in controller ticks.
    world.require("plug", "plugging a device in")
    p = world.empty_port(avoid=(motor_port,))
    world.plug(p, ("passive", 1))
    clock = TickClock(hat, motor_port)
    clock.run(100)
    world.plug_only(p, ("passive", 2))
    events = clock.run(2000)
    hat.exchange("debug 0")
    on = clock.ticks_at(events, f"P{p}: connected to passive ID 2")
    assert on, f"no 'connected to passive ID 2' within 2 s of the swap: {[e.text for e in events][-8:]!r}"
    if hat.feature("passive_connect_repeats"):
        return                         # R1 scans from scratch every time and says no `disconnected`
    gone = clock.ticks_at(events, f"P{p}: disconnected")
    assert gone and gone[0] <= on[0], f"'disconnected' at ticks {gone}, 'connected' at {on}"
    # Five more scans after the one that found the new ID, four at the least (10 ms a tick).
    least = 4 * int(hat.feature("passive_scan_ms")) // 10
    assert on[0] - gone[0] >= least, \
        f"'connected to passive ID 2' {on[0] - gone[0]} ticks after 'disconnected': six scans take " \
        f"{least} or more"


@pytest.mark.req("EVT-DISCONNECT")
@pytest.mark.parametrize("spec", [("active", SENSOR), ("passive", 1)], ids=["active", "passive"])
def test_unplug_says_disconnected(hat: HatUnderTest, world: PortNeeds, verdict: Verdict, empty_port: int,
                                  spec: tuple) -> None:
    world.require("unplug", "unplugging a device")
    p = empty_port
    world.plug(p, spec)
    mark = hat.mark()
    hat.world(f"@unplug {p}")
    if spec[0] == "active":
        hat.wait_for(lambda e: e.text == f"P{p}: timeout during data phase: disconnecting", 1, 3000)
    hat.wait_for(lambda e: e.text == f"P{p}: disconnected", 1, 1500)
    hat.wait_ms(300)
    texts = _texts(hat.since(mark))
    said = f"P{p}: disconnected" in texts
    if spec[0] == "active":
        # docs/FIRMWARE-BEHAVIOUR.md#fb-active: the data-phase watchdog (>500 ms) notices an active
        # device is gone.
        assert f"P{p}: timeout during data phase: disconnecting" in texts, \
            f"unplugged an active device: expected `P{p}: timeout during data phase: disconnecting`, " \
            f"came {texts[:8]}"
        r1_way = not said
    else:
        r1_way = not said and not any(t.startswith(f"P{p}:") for t in texts[-3:])
    verdict.document(said, key="NO-DISCONNECTED-LINE", firmware_ok=r1_way,
                     seen=f"lines after unplug: {texts[:8]!r}")
    assert texts.count(f"P{p}: disconnected") <= 1, \
        f"one unplug: expected at most one `P{p}: disconnected`, came {texts[:8]}"


@pytest.mark.req("EVT-DISCONNECT", "FW-SETUP-TIMEOUT")
def test_device_gone_during_setup_times_out(hat: HatUnderTest, world: PortNeeds, empty_port: int) -> None:
    # FIRMWARE-BEHAVIOUR#fb-active: a device that stops talking during its set-up is dropped with
    # `P<p>: timeout during setup phase: disconnecting` once 2000 ms passed with no message.
    world.require("unplug", "unplugging a device")
    p = empty_port
    mark = hat.mark()
    world.plug_only(p, ("active", SENSOR))
    hat.expect(lambda e: e.text == f"P{p}: connecting to active device" and e in hat.since(mark), 3000)
    world.plug_only(p, None)
    line = f"P{p}: timeout during setup phase: disconnecting"
    hat.wait_for(lambda e: e.text == line, 1, 4000)
    texts = _texts(hat.since(mark))
    assert line in texts, f"no {line!r} after the device went mid-set-up: {texts[-8:]!r}"
    assert not any(t.startswith(f"P{p}: established") for t in texts), \
        f"a device gone mid-set-up must not be established; came {texts[-8:]}"


@pytest.mark.req("DEV-PORTS", "EVT-CONNECT")
@pytest.mark.parametrize("port", [0, 1, 2, 3])
def test_every_port_hosts_an_active_device(hat: HatUnderTest, world: PortNeeds, port: int) -> None:
    # Document: ports 0..3, each may hold an active device. Its data must reach the host on each.
    # A port that has an active device already keeps it (the other cases' devices stay put).
    if world.layout()[port].kind != "active":
        world.plug(port, ("active", SENSOR))
    reply = hat.exchange(f"port {port} ; selonce 0")
    lines = [e.text for e in reply.events + hat.wait_for(
        lambda e: e.text.startswith(f"P{port}M0:"), 1, 2000) if e.text.startswith(f"P{port}M0:")]
    assert reply.errors == 0 and lines, f"no data from the sensor on port {port}: {reply.raw!r}"


@pytest.mark.req("FW-STALL-LINE", "CMD-LIST")
def test_stall_line_only_past_2_ms(hat: HatUnderTest, world: PortNeeds) -> None:
    # FIRMWARE-BEHAVIOUR#fb-stall: `deltat=XXXXXXXX` (8 upper-case hex digits) when one main-loop pass
    # took more than 2 ms, e.g. a long `list`. It may not come at all; when it comes, it says > 2.
    for port in range(4):
        if world.layout()[port].kind != "active":
            world.plug(port, ("active", SENSOR))
    mark = hat.mark()
    for _ in range(3):
        hat.exchange("list", timeout_ms=3000)
    hat.exchange("help")
    # A PID line every 10 ms tick lengthens some passes to about 2 ms: not a stall yet.
    TickClock(hat, world.active(MOTOR)).run(1000)
    hat.exchange("debug 0")
    # Any line that begins like one is judged as one: `Deltat=...` is a stall line printed wrongly.
    stalls = [e.text for e in hat.since(mark) if e.text.lower().startswith("deltat")]
    bad = [t for t in stalls if not re.fullmatch(r"deltat=[0-9A-F]{8}", t) or int(t[7:], 16) <= 2]
    assert not bad, f"stall lines must show more than 2 ms in 8 upper-case hex digits: {bad}"
