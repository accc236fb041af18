"""When data lines come, in every reporting mode (docs/FIRMWARE-BEHAVIOUR.md#fb-reporting):
`select` of a mode, of a variable and of a combi every 100 ms; `selrate N` every N ms (the timer
restarts from 0 after each line, so an interval may stretch by a loop pass); `selrate 0` one line
per data message. `selonce` is timed in test_firmware_facts.py.

HAT time is read from the HAT itself (probes.TickClock: a quiet PID printing one `debug 16` line
per 10 ms tick), so the counts hold however the target's speed compares to the wall clock.
"""
from __future__ import annotations

import re
from typing import Tuple

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import accepted
from ..needs import PortNeeds
from ..probes import DATA_LINE, MOTOR, TickClock
from ..verdict import Verdict

WINDOW_MS = 1000


def count_lines(hat: HatUnderTest, clock: TickClock, head: str) -> int:
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
def test_select_reports_every_100_ms(hat: HatUnderTest, motor_port: int, line: str, head: str) -> None:
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
def test_selrate_period(hat: HatUnderTest, motor_port: int, rate: int) -> None:
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
def test_selrate_0_reports_each_message(hat: HatUnderTest, world: PortNeeds, empty_port: int,
                                        every: int) -> None:
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


# A report's head, and the bytes a report line can hold (fb-data-lines; a CR whose LF was lost): a stub
# of only these, in front of a whole report, is the beginning of a report the ring cut (fb-reports-whole).
REPORT_HEAD = re.compile(r"P[0-3][MC][0-9]+:")
REPORT_STUB = re.compile(r"[PMC0-9:+\-. \r]+")
RING_HALF = 4096                   # bytes (fb-tx-ring)
FLOOD_MS = 1500
DRAIN_MS = 1000
WIRE_BYTES_PER_MS = 11.52          # 115200 baud, 10 bits a byte (fb-uart)


def cut_report(text: str, other_output: bool) -> bool:
    """True if the line ``text`` holds a report the ring cut: a report's head not followed by a whole
    report, or (unless other output could have filled the ring) a report's first bytes in front of
    another line."""
    heads = [m.start() for m in REPORT_HEAD.finditer(text)]
    if not heads:
        return not other_output and bool(REPORT_STUB.fullmatch(text)) and text.startswith("P")
    pieces = [text[a:b] for a, b in zip(heads, heads[1:] + [len(text)])]
    if any(not DATA_LINE.fullmatch(piece) for piece in pieces):
        return True
    stub = text[:heads[0]]
    return bool(stub) and not other_output and bool(REPORT_STUB.fullmatch(stub))


@pytest.mark.req("FW-REPORTS-WHOLE", "CMD-SELECT-MODE", "LINK-SERIAL")
def test_reports_beyond_the_wire_are_held_back_not_cut(hat: HatUnderTest, world: PortNeeds, verdict: Verdict,
                                                       empty_port: int) -> None:
    # FIRMWARE-BEHAVIOUR#fb-reports-whole: from R5 a report is begun only while half the 8192-byte
    # transmit ring is free, so two motors each sending every millisecond with `selrate 0` (more
    # reports than 115200 baud carries) give fewer lines, each one whole.
    if not hat.feature("tx_throttle_reports"):
        pytest.skip("R1-R4 do not hold reports back: a full ring cuts them like any other line "
                    "(docs/FIRMWARE-BEHAVIOUR.md#fb-tx-ring)")
    world.require("rate", "making a device send at a chosen rate (@rate)")
    ports = (empty_port, world.empty_port(avoid=(empty_port,)))
    for p in ports:
        world.plug(p, ("active", MOTOR))
    sent = " ; ".join(f"port {p} ; select 1 ; selrate 0" for p in ports)
    try:
        for p in ports:
            world.action(f"@rate {p} 1")
        mark = hat.mark()
        reply = hat.exchange(sent)
        assert reply.errors == 0, f"sent `{sent}`; the HAT answered {reply.raw!r}"
        # No fence while the ring may be full (its answer could be cut too): the flood ends by the
        # world's hand, and what the ring holds (at most 8192 bytes, 0.7 s) drains before a line is sent.
        hat.wait_ms(FLOOD_MS)
        for p in ports:
            world.action(f"@rate {p} 100")
        hat.wait_ms(DRAIN_MS)
        events = hat.since(mark)
    finally:
        hat.exchange(" ; ".join(f"port {p} ; select" for p in ports))
        for p in ports:
            world.unplug(p)
    texts = [e.text.strip("\n") for e in events]
    reports = [t for t in texts if DATA_LINE.fullmatch(t)]
    # A line's first bytes alone may be any line's: only output other than reports, at least half a
    # ring of it, can have filled the ring while reports are held back at half.
    other = sum(len(t) + 2 for t in texts if t and not REPORT_STUB.fullmatch(t)) >= RING_HALF
    cut = [t for t in texts if cut_report(t, other)]
    assert not cut, (f"sent `{sent}` with both motors sending every ms; docs/FIRMWARE-BEHAVIOUR.md"
                     f"#fb-reports-whole: a report is begun only into a half-empty ring, so it is never "
                     f"cut; {len(cut)} of {len(reports) + len(cut)} report lines came cut, e.g. {cut[:3]!r}")
    assert reports, f"sent `{sent}`; no report line came in {FLOOD_MS} ms of HAT time"
    sent_bytes = sum(len(e.raw) + 2 for e in events)
    if sent_bytes < 0.9 * WIRE_BYTES_PER_MS * FLOOD_MS:
        verdict.note(f"the HAT sent {sent_bytes} bytes in {FLOOD_MS} ms, less than 115200 baud carries: "
                     "its transmit ring never filled, so no report had to be held back")
