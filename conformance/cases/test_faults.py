"""Power faults (document §Device Power; docs/FIRMWARE-BEHAVIOUR.md#fb-power-faults for timing and
wording).

PWR-PORT-FAULT: printed for as long as the 3.3 V fault persists (at 1 Hz after a >10 ms
deglitch) and not after. PWR-MOTOR-FAULT / PWR-MOTOR-LATCH: printed repeatedly (R2+: with a
register dump) while the driver's latch holds, which outlives its cause until clear_faults.
Time is counted in controller ticks (`debug 16` lines, 10 ms each), so intervals are HAT time
whatever the wall clock does; tolerance ±6%.
"""
from __future__ import annotations

import re
from typing import List

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import accepted
from ..needs import PortNeeds
from ..probes import TickClock

DUMP_HEADER = " Port 4D 4E 4F"
# Three spaces, the port, one space, then three times (space + 2 hex digits)
# (docs/FIRMWARE-BEHAVIOUR.md#fb-motor-fault-dump).
DUMP_ROW = re.compile(r"   ([0-3]) ((?: [0-9A-F]{2}){3})")


def gaps(ticks: List[int]) -> List[int]:
    return [b - a for a, b in zip(ticks, ticks[1:])]


def about_a_second(ticks: List[int]) -> bool:
    # 1000 ms (port fault, R1 motor fault) or ~1011 ms (R2+ motor fault: >10 ms low, then 1000 ms hold-off).
    return all(94 <= g <= 107 for g in gaps(ticks))


@pytest.fixture
def no_faults(hat: HatUnderTest, world: PortNeeds):
    yield
    if world.can("portfault"):
        world.action("@portfault 0")
    if world.can("motorfault"):
        world.action("@motorfault 0")
    hat.exchange("clear_faults")


@pytest.mark.req("PWR-PORT-FAULT")
def test_port_power_fault_repeats_while_present_and_stops_after(hat: HatUnderTest, world: PortNeeds,
                                                                motor_port: int,
                                                                no_faults: None) -> None:
    world.require("portfault", "a way to overload the 3.3 V port supply")
    clock = TickClock(hat, motor_port)
    world.action("@portfault 1")
    # The first report comes at once and the next a second later: three within 300 ms is a HAT
    # repeating it far too often. Such a HAT fills its TX ring at once and then drops bytes, so
    # the rate is judged on its first, whole lines and the fault ended before the ring spills.
    first = hat.wait_for(lambda e: e.text == "Port power fault", 3, 300)
    burst = sum(1 for e in first if e.text == "Port power fault")
    if burst >= 3:
        world.action("@portfault 0")
        hat.collect_ms(1500)             # what the ring holds drains (two full rings' time)
    assert burst < 3, f"{burst} reports within 300 ms of the fault, 1 Hz expected"
    clock.include(first)
    during = clock.run(3300)
    world.action("@portfault 0")
    released = clock.count(during)
    events = during + clock.run(2500)
    hat.exchange("debug 0")
    ticks = clock.ticks_at(events, "Port power fault")
    # >10 ms deglitch, then at once; the tick count also holds lines already in flight when the
    # fault was applied, hence the margin.
    assert ticks and ticks[0] <= 50, f"first report at tick {ticks[:1]}"
    assert 3 <= len([t for t in ticks if t <= released]) <= 5, f"reports at ticks {ticks}"
    assert about_a_second(ticks), f"intervals {gaps(ticks)} ticks, 1 Hz expected"
    # Reports stop with the fault (one may already be on its way at the moment of release).
    late = [t for t in ticks if t > released + 30]
    assert not late, f"reports after the release at tick {released}: {ticks}"


@pytest.mark.req("PWR-MOTOR-FAULT", "PWR-MOTOR-LATCH", "CMD-CLEAR-FAULTS")
def test_motor_fault_is_latched_until_cleared(hat: HatUnderTest, world: PortNeeds, motor_port: int,
                                              no_faults: None) -> None:
    world.require("motorfault", "a way to trip a motor driver's fault")
    p = motor_port
    clock = TickClock(hat, p)
    world.action(f"@motorfault 1 {p} 01 00 00")
    events = clock.run(1500)
    removed = clock.count(events)
    world.action(f"@motorfault 0 {p}")           # the cause is gone; the latch stays
    events += clock.run(2800)
    ticks = clock.ticks_at(events, "Motor power fault")
    assert len(ticks) >= 3, f"reports at ticks {ticks} in 4.3 s, cause removed at tick {removed}"
    assert about_a_second(ticks), f"intervals {gaps(ticks)} ticks, about 1 Hz expected"
    assert len([t for t in ticks if t > removed + 30]) >= 2, \
        f"reports at ticks {ticks}: the fault must go on being reported after its cause is gone at {removed}"
    if hat.feature("motor_fault_report") == "dump_holdoff":
        texts = [e.text for e in events if not e.text.startswith(f"P{p}: pv=")]
        i = texts.index("Motor power fault")
        assert texts[i + 1] == DUMP_HEADER, "R2+: the register dump follows at once"
        rows = [DUMP_ROW.fullmatch(t) for t in texts[i + 2:i + 6]]
        matched = [r for r in rows if r is not None]
        assert len(matched) == 4 and [int(r.group(1)) for r in matched] == [0, 1, 2, 3], texts[i + 1:i + 6]
        assert not any(re.fullmatch(r" +[0-9]+ ?(?: [0-9A-F]{2}){3}", t) for t in texts[i + 6:i + 7]), \
            f"four ports, four rows: {texts[i + 1:i + 7]}"
        assert matched[p].group(2) == " 01 00 00", f"port {p}'s flags as latched: {matched[p].group(0)!r}"
    reply = hat.exchange("clear_faults")
    accepted(reply)
    after = clock.run(2500)
    hat.exchange("debug 0")
    late = [t for t in clock.ticks_at(after, "Motor power fault") if t > 30]
    assert not late, f"clear_faults must end the reports; seen at ticks {late} after it"


@pytest.mark.req("PWR-MOTOR-LATCH", "CMD-CLEAR-FAULTS")
def test_clear_faults_with_the_cause_still_present(hat: HatUnderTest, world: PortNeeds, motor_port: int,
                                                   no_faults: None) -> None:
    world.require("motorfault", "a way to trip a motor driver's fault")
    p = motor_port
    clock = TickClock(hat, p)
    world.action(f"@motorfault 1 {p}")
    clock.run(300)
    hat.exchange("clear_faults")
    still = clock.ticks_at(clock.run(2600), "Motor power fault")
    world.action(f"@motorfault 0 {p}")
    hat.exchange("clear_faults")
    rest = [t for t in clock.ticks_at(clock.run(2200), "Motor power fault") if t > 30]
    hat.exchange("debug 0")
    assert len(still) >= 2, "with the cause present the fault latches again and is reported again"
    assert not rest, f"once the cause is gone, clear_faults ends it (seen at ticks {rest})"


DEGLITCH_MS = 10      # a port fault is reported once it has lasted more than this (fb-power-faults)


@pytest.mark.req("PWR-PORT-FAULT", "FW-FAULT-DEGLITCH")
@pytest.mark.parametrize("fault_ms", [DEGLITCH_MS - 1, DEGLITCH_MS, DEGLITCH_MS + 1],
                         ids=["9ms", "10ms", "11ms"])
def test_port_power_fault_deglitch_boundary(hat: HatUnderTest, world: PortNeeds, no_faults: None,
                                            fault_ms: int) -> None:
    # FIRMWARE-BEHAVIOUR#fb-fault-deglitch: the firmware counts whole ms since it last saw the signal
    # high, so a fault of 9 or 10 ms is never reported and one of 11 ms once, at once (the next would
    # come 1000 ms later, had the fault lasted). The world starts the fault half-way through a ms.
    world.require("faultpulse", "a port power fault timed to the millisecond by the HAT's clock "
                                "(@portfault 1 MS)")
    action = f"@portfault 1 {fault_ms}"
    world.action(action)
    events = hat.collect_ms(1500)
    reports = [e.t for e in events if e.text == "Port power fault"]
    want = 1 if fault_ms > DEGLITCH_MS else 0
    assert len(reports) == want, (
        f"world `{action}` (the 3.3 V port supply low for {fault_ms} ms of HAT time); "
        f"docs/FIRMWARE-BEHAVIOUR.md#fb-fault-deglitch: a fault longer than {DEGLITCH_MS} ms is reported "
        f"once at once, a shorter one never, so {want} `Port power fault` line expected in 1500 ms; "
        f"{len(reports)} came")
