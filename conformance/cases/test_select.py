"""select / selonce / selrate / combi / write1 / write2 (document §Command Summary;
docs/FIRMWARE-BEHAVIOUR.md#fb-data for the line formats and the reporting engine, #fb-combi for
combi)."""
from __future__ import annotations

import re
import struct

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import accepted, rejected, same
from ..needs import PortNeeds
from ..oracles.floatfmt import fw_float
from ..probes import TickClock, data_lines
from ..verdict import Verdict

# docs/FIRMWARE-BEHAVIOUR.md#fb-data-ints: integers are `+N`, `-N`, or a space then `0`; floats come
# from the float printer (#fb-float).
INT = r"(?:\+[1-9][0-9]*|-[1-9][0-9]*| 0)"
MODE_LINE = re.compile(rf"P([0-3])M([0-9]+):((?: {INT})+)")
HEX_LINE = re.compile(r"P[0-3]M[0-9]+:(?: [0-9A-Fa-f]{2})+")
COLOUR = 0x3D            # SPIKE colour sensor: modes 0..9, so it has modes above 7


def reports(hat: HatUnderTest, port: int, hat_ms: float, reply=None) -> list:
    """Data lines of ``port`` during ``hat_ms`` (for checks that expect few or none)."""
    events = (reply.events if reply is not None else []) + hat.collect_ms(hat_ms)
    return data_lines(events, port)


def at_least(hat: HatUnderTest, port: int, count: int, head: str = "", reply=None,
             max_hat_ms: float = 2000) -> list:
    """Data lines of ``port`` (starting with ``head``) once ``count`` have come, or at the deadline."""
    prefix = head or f"P{port}"
    events = (reply.events if reply is not None else [])
    events += hat.wait_for(lambda e: e.text.startswith(prefix), count, max_hat_ms)
    return [ln for ln in data_lines(events, port) if ln.startswith(prefix)]


@pytest.mark.req("CMD-SELECT-MODE")
def test_select_mode_reports_repeatedly(hat: HatUnderTest, verdict: Verdict, motor_port: int) -> None:
    p = motor_port
    reply = hat.exchange(f"port {p} ; select 1")
    lines = at_least(hat, p, 3, f"P{p}M1:", reply)
    assert reply.errors == 0 and len(lines) >= 3, f"{len(lines)} reports of mode 1 in 2 s"
    hex_ok = all(HEX_LINE.fullmatch(ln) for ln in lines)
    decimal = [MODE_LINE.fullmatch(ln) for ln in lines]
    decimal_ok = all(decimal)
    verdict.document(hex_ok, key="SELECT-PRINTS-DECIMAL", firmware_ok=decimal_ok, seen=repr(lines[:3]))
    # Mode 1 (SPEED) has one int8 value (devices.json): one value per line.
    assert all(m is not None and len(m.group(3).replace(" 0", "0").split()) == 1 for m in decimal), \
        f"mode 1 (SPEED) has one value (protocol/devices.json): expected one value a line, came {lines[:3]}"


@pytest.mark.req("CMD-SELECT-OFF")
def test_select_without_argument_stops_reports(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    hat.exchange(f"port {p} ; select 1")
    assert at_least(hat, p, 2), "no reports to stop"
    reply = hat.exchange("select")
    same(reply, b"\r\n")
    assert not reports(hat, p, 400), "reports continued after `select`"


@pytest.mark.req("CMD-SELECT-VAR")
@pytest.mark.parametrize("fmt,offset", [("s2", 0), ("u1", 0), ("s1", 1), ("u2", 0), ("f4", 0)])
def test_select_variable_prints_one_float(hat: HatUnderTest, world: PortNeeds, motor_port: int, fmt: str,
                                          offset: int) -> None:
    p = motor_port
    payload = struct.pack("<hh", -180, 5) if fmt != "f4" else struct.pack("<f", 2.5)
    exact = world.can("data")
    if exact:
        world.action(f"@data {p} 4 " + " ".join(f"{b:02X}" for b in payload))
    try:
        reply = hat.exchange(f"port {p} ; select 4 {offset} {fmt}")
        lines = at_least(hat, p, 2, f"P{p}V:", reply)
    finally:
        if exact:
            world.action(f"@data {p} 4 auto")
    assert reply.errors == 0 and len(lines) >= 2, f"{len(lines)} variable reports"
    # docs/FIRMWARE-BEHAVIOUR.md#fb-data-var: `P<p>V: <float>`, the mode not shown, always the
    # float printer.
    assert all(re.fullmatch(r"P[0-3]V: -?[0-9.]+(E-?[0-9]+)?", ln) for ln in lines), lines[:3]
    if exact:
        code = {"s2": "<h", "u1": "<B", "s1": "<b", "u2": "<H", "f4": "<f"}[fmt]
        value = struct.unpack_from(code, payload, offset)[0]
        assert lines[-1] == f"P{p}V: {fw_float(value)}", \
            f"expected `P{p}V: {fw_float(value)}` (docs/FIRMWARE-BEHAVIOUR.md#fb-data-var), " \
            f"came {lines[-1]!r}"


@pytest.mark.req("CMD-SELONCE")
def test_selonce_mode_reports_once(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    reply = hat.exchange(f"port {p} ; selonce 1")
    lines = at_least(hat, p, 1, reply=reply) + reports(hat, p, 600)
    assert reply.errors == 0 and len(lines) == 1, f"selonce gave {lines}"


@pytest.mark.req("CMD-SELONCE")
def test_selonce_variable_reports_once(hat: HatUnderTest, verdict: Verdict, motor_port: int) -> None:
    p = motor_port
    reply = hat.exchange(f"port {p} ; selonce 3 0 s2")
    lines = at_least(hat, p, 1, reply=reply) + reports(hat, p, 600)
    verdict.document(len(lines) == 1, key="SELONCE-VAR-REPEATS", firmware_ok=len(lines) >= 4,
                     seen=f"{len(lines)} reports in 600 ms: {lines[:3]}")


@pytest.mark.req("FW-SELRATE")
def test_selrate_sets_the_report_interval(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    reply = hat.exchange(f"port {p} ; select 1 ; selrate 25")
    if not hat.has("selrate"):
        rejected(reply)
        return
    clock = TickClock(hat, p)             # a quiet PID on mode 3: ticks every 10 ms
    hat.exchange(f"port {p} ; select 1 ; selrate 25")
    clock.run(100)
    n = len([ln for ln in data_lines(clock.run(1000), p) if ln.startswith(f"P{p}M1:")])
    hat.exchange("debug 0")
    # Every 25 ms (timer reset to 0 each report, so intervals may drift up a little): ~40 in 1 s.
    assert 25 <= n <= 45, f"{n} reports in 100 ticks at selrate 25"


@pytest.mark.req("CMD-COMBI", "EX-MOTOR-COMBI")
def test_combi_reports_the_chosen_values(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    reply = hat.exchange(f"port {p} combi 0 1 0 2 0 3 0")     # Appendix A, without `;`
    accepted(reply, "Appendix A's line")
    reply = hat.exchange("select 0")
    lines = at_least(hat, p, 2, f"P{p}C0:", reply)
    assert len(lines) >= 2, f"no combi reports: {reports(hat, p, 10)}"
    for ln in lines:
        m = re.fullmatch(rf"P{p}C0:( {INT})( {INT})( {INT})", ln)
        assert m, f"expected SPEED, POS and APOS: {ln!r}"
        assert -180 <= int(m.group(3)) <= 179, "APOS is -180..179 (devices.json)"
    hat.exchange("select ; combi 0")


@pytest.mark.req("CMD-COMBI-OFF")
def test_combi_index_alone_deconfigures(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    hat.exchange(f"port {p} ; combi 0 1 0 3 0 ; combi 0 ; select 0")
    lines = at_least(hat, p, 2)
    assert lines and all(ln.startswith(f"P{p}M0:") for ln in lines), \
        f"after `combi 0`, `select 0` is mode 0 again: {lines[:3]}"


@pytest.mark.req("FW-COMBI-CLEARS-SELECTION")
def test_combi_and_the_selection(hat: HatUnderTest, motor_port: int) -> None:
    p = motor_port
    hat.exchange(f"port {p} ; select 1")
    assert at_least(hat, p, 2), f"sent `select 1` on port {p}: expected its data lines, fewer than 2 came"
    hat.exchange("combi 1 1 0 3 0")
    after = at_least(hat, p, 2, max_hat_ms=600) if not hat.feature("combi_clears_selection") \
        else reports(hat, p, 400)
    hat.exchange("select ; combi 1")
    if hat.feature("combi_clears_selection"):
        assert not after, "R5+: combi stops the reports (docs/FIRMWARE-BEHAVIOUR.md#fb-select-resend)"
    else:
        assert after, "R1-R4: combi leaves the selection alone"


@pytest.mark.req("DEV-MODES", "CMD-SELECT-MODE")
@pytest.mark.parametrize("mode", [0, 5, 8, 9])
def test_modes_of_a_device_with_more_than_eight(hat: HatUnderTest, world: PortNeeds, verdict: Verdict,
                                                mode: int) -> None:
    p = world.active(COLOUR)
    reply = hat.exchange(f"port {p} ; plimit 1 ; set -1 ; select {mode}")
    if mode < 8:
        lines = at_least(hat, p, 1, f"P{p}M{mode}:", reply)
    else:
        lines = [ln for ln in reports(hat, p, 500, reply) if ln.startswith(f"P{p}M{mode}:")]
    hat.exchange("select ; set 0")
    if mode < 8:
        assert lines, f"mode {mode} of the colour sensor printed nothing"
        return
    verdict.document(bool(lines), key="HIGH-MODES-SILENT", firmware_ok=not lines,
                     seen=f"select {mode}: {lines[:2]}")


@pytest.mark.req("CMD-WRITE1", "CMD-WRITE2", "EX-DISTANCE-LEDS")
@pytest.mark.parametrize("line", ["write1 c5 10 20 30 40", "write1 c0 5", "write1 40", "write2 44 11 22",
                                  "write1 c2 12 23 34 45 12 23 34 45 12", "write1 C5 0A 0b 123 fff"])
def test_write_accepts_hex_bytes(hat: HatUnderTest, world: PortNeeds, motor_port: int, line: str,
                                 verdict: Verdict) -> None:
    try:
        reply = hat.exchange(f"port {motor_port} ; {line}")
    finally:
        world.replug(motor_port)      # the message changed the motor itself (a preset position ...)
    same(reply, b"\r\n")
    verdict.note("what reaches the device is only visible on the device side "
                 "(docs/FIRMWARE-BEHAVIOUR.md#fb-device-messages)")


# The byte-exact examples of docs/FIRMWARE-BEHAVIOUR.md#fb-write, framed as #fb-framing says: the
# header's length bits replaced, zero padding to 2^L payload bytes, the checksum 0xFF XOR every byte
# before it.
FRAMES = {"write1 c5 10 20 30 40": "D5 10 20 30 40 6A", "write1 c0 5": "C0 05 3A", "write1 40": "40 00 BF",
          "write1 c2 12 23 34 45 12 23 34 45 12": "E2 12 23 34 45 12 23 34 45 12 00 00 00 00 00 00 00 0F",
          # #fb-write's `write2 44 11 22` -> `44 11 22 88` is a CMD header, which a device reads
          # with one header byte (its receiving rules, #fb-lpf2-receive), so it does not take that
          # frame whole. With an INFO header (a command byte follows) by the same rule: 80 11 22,
          # then FF ^ 80 ^ 11 ^ 22 = 4C.
          "write2 80 11 22": "80 11 22 4C"}


@pytest.mark.req("CMD-WRITE1", "CMD-WRITE2")
@pytest.mark.parametrize("line", list(FRAMES))
def test_write_delivers_the_framed_message(hat: HatUnderTest, world: PortNeeds, motor_port: int,
                                           line: str) -> None:
    # Only the device side shows it: skipped (with the reason) on a target without that view.
    try:
        reply, frames = world.frames_to_device(motor_port, f"port {motor_port} ; {line}")
    finally:
        world.replug(motor_port)      # the message changed the motor itself (a preset position ...)
    assert reply.raw == b"\r\n", f"`{line}`: {reply.raw!r}"
    expected = bytes.fromhex(FRAMES[line])
    got = [f.hex(" ").upper() for f in frames]
    assert expected in frames, f"`{line}` must reach the device as {FRAMES[line]}; it received {got}"


@pytest.mark.req("CMD-WRITE1", "FW-ERROR")
@pytest.mark.parametrize("line", ["write1 0x12", "write1", "write2", "write1 c5 zz"])
def test_write_rejects_what_is_not_hex(hat: HatUnderTest, motor_port: int, line: str) -> None:
    rejected(hat.exchange(f"port {motor_port} ; {line}"))


@pytest.mark.req("CMD-COMBI", "FW-ERROR")
@pytest.mark.parametrize("line", ["combi 0 1 0 2", "combi 0 1", "combi"])
def test_combi_with_a_mode_but_no_dataset_is_an_error(hat: HatUnderTest, motor_port: int, line: str) -> None:
    # FIRMWARE-BEHAVIOUR#fb-errors: `combi` with an odd number of integers (or none) prints `Error`.
    reply = hat.exchange(f"port {motor_port} ; {line}")
    hat.exchange(f"port {motor_port} ; combi 0")
    assert reply.raw == b"\r\nError\r\n", f"`{line}`: {reply.raw!r}"
