"""When data lines come, in every reporting mode (docs/FIRMWARE-BEHAVIOUR.md#fb-reporting):
`select` of a mode, of a variable and of a combi every 100 ms; `selrate N` every N ms (the timer
restarts from 0 after each line, so an interval may stretch by a loop pass); `selrate 0` one line
per data message. `selonce` is timed in test_firmware_facts.py.

HAT time is read from the HAT itself (probes.TickClock: a quiet PID printing one `debug 16` line
per 10 ms tick), so the counts hold however the target's speed compares to the wall clock.
"""
from __future__ import annotations

from typing import Tuple

import pytest

from ..link import Hat
from ..mismatch import accepted
from ..needs import World
from ..probes import MOTOR, TickClock

WINDOW_MS = 1000


def count_lines(hat: Hat, clock: TickClock, head: str) -> int:
    """Lines starting ``head`` in WINDOW_MS of controller time, after 300 ms to settle (the
    first line of a timed report comes a period after the first data)."""
    clock.run(300)
    events = clock.run(WINDOW_MS)
    assert clock.count(events) >= WINDOW_MS // 10, \
        f"only {clock.count(events)} controller ticks seen: the HAT's time could not be read"
    return sum(1 for e in events if e.text.startswith(head))


def periodic(lo_ms: float, hi_ms: float) -> Tuple[int, int]:
    """How many lines the window holds at ``lo_ms``..``hi_ms`` per line (one more or less at its ends)."""
    return int(WINDOW_MS // hi_ms) - 1, int(WINDOW_MS // lo_ms) + 1


@pytest.mark.req("CMD-SELECT-MODE", "CMD-SELECT-VAR", "CMD-COMBI")
@pytest.mark.parametrize("line,head", [("select 1", "M1:"), ("select 4 0 s2", "V:"),
                                       ("combi 0 1 0 3 0 ; select 0", "C0:")],
                         ids=["mode", "variable", "combi"])
def test_select_reports_every_100_ms(hat: Hat, motor_port: int, line: str, head: str) -> None:
    # R1-R4: a fixed 100 ms; R5+: `select` sets the rate to 100 ms, an interval may stretch by a pass.
    p = motor_port
    clock = TickClock(hat, p)
    try:
        reply = hat.exchange(f"port {p} ; {line}")
        assert reply.errors == 0, f"`{line}`: {reply.raw!r}"
        n = count_lines(hat, clock, f"P{p}{head}")
    finally:
        hat.exchange(f"port {p} ; select ; combi 0 ; debug 0")
    lo, hi = periodic(100, 102)
    assert lo <= n <= hi, f"`{line}`: {n} lines in {WINDOW_MS} ms of HAT time, one per 100 ms expected"


@pytest.mark.req("FW-SELRATE", "CMD-SELECT-MODE")
@pytest.mark.parametrize("rate", [3, 25, 40, 250])
def test_selrate_period(hat: Hat, motor_port: int, rate: int) -> None:
    p = motor_port
    if not hat.has("selrate"):
        reply = hat.exchange(f"port {p} ; select 1 ; selrate {rate}")
        assert reply.raw.endswith(b"Error\r\n"), \
            f"sent {reply.sent!r}: {hat.profile.name} has no selrate, expected `Error`; came {reply.raw!r}"
        hat.exchange("select")
        return
    clock = TickClock(hat, p)
    try:
        reply = hat.exchange(f"port {p} ; select 1 ; selrate {rate}")
        accepted(reply)
        n = count_lines(hat, clock, f"P{p}M1:")
    finally:
        hat.exchange(f"port {p} ; select ; debug 0")
    # The timer restarts from 0 after each line: N ms, or N plus up to a couple of ms of loop pass.
    lo, hi = periodic(rate, rate + 2)
    assert lo <= n <= hi, f"selrate {rate}: {n} lines in {WINDOW_MS} ms of HAT time"


@pytest.mark.req("FW-SELRATE", "CMD-SELECT-MODE")
@pytest.mark.parametrize("every", [20, 50])
def test_selrate_0_reports_each_message(hat: Hat, world: World, empty_port: int, every: int) -> None:
    # FIRMWARE-BEHAVIOUR#fb-reporting-r5: `selrate 0` prints at most one line per pass in which a new
    # message arrived, and nothing again until the next one: as many lines as the device sends.
    # A motor of its own: `@rate` cannot be taken back, so the motor goes when the case ends.
    p = empty_port
    if not hat.has("selrate"):
        reply = hat.exchange(f"port {p} ; select 1 ; selrate 0")
        assert reply.raw.endswith(b"Error\r\n"), \
            f"sent {reply.sent!r}: {hat.profile.name} has no selrate, expected `Error`; came {reply.raw!r}"
        hat.exchange("select")
        return
    world.require("rate", "making a device send at a chosen rate (@rate)")
    world.plug(p, ("active", MOTOR))
    clock = TickClock(hat, p)
    world.action(f"@rate {p} {every}")
    try:
        reply = hat.exchange(f"port {p} ; select 1 ; selrate 0")
        accepted(reply)
        n = count_lines(hat, clock, f"P{p}M1:")
    finally:
        hat.exchange(f"port {p} ; select ; debug 0")
        world.unplug(p)
    expected = WINDOW_MS // every
    assert expected - 2 <= n <= expected + 1, \
        f"selrate 0 with a message every {every} ms: {n} lines in {WINDOW_MS} ms, {expected} expected"
