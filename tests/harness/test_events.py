"""The line classifier on the exact example lines of FIRMWARE-FACTS, and the line splitter
(prompts without CRLF, partial lines, the echo of the host's own line)."""
from __future__ import annotations

import math

import pytest

from buildhat_conformance.harness.events import KINDS, classify, parse_value
from buildhat_conformance.harness.line_splitter import LineSplitter, expected_echo

# (line exactly as FIRMWARE-FACTS prints it, kind, fields that must be present)
FACTS_LINES = [
    ("Firmware version: 1737564117 2025-01-22T16:41:57+00:00", "version",
     {"number": 1737564117, "version": "1737564117 2025-01-22T16:41:57+00:00"}),
    ("BuildHAT bootloader version 1737564075 2025-01-22T16:41:15+00:00", "bootloader_version",
     {"number": 1737564075}),
    ("BuildHAT bootloader version 1.0", "bootloader_version", {"number": None}),
    ("1631457600", "bootloader_version", {"number": 1631457600, "bare": True}),
    ("7.20 V", "vin", {"volts": 7.2}),
    ("18.80 V", "vin", {"volts": 18.8}),
    ("0.00 V", "vin", {"volts": 0.0}),
    ("Error", "error", {}),
    ("", "blank", {}),
    ("P0: no device detected", "list_port", {"port": 0, "state": "none"}),
    ("P2: connected to passive ID 8", "connected_passive", {"port": 2, "state": "passive", "id": 8}),
    ("P3: connected to active ID 30", "list_port", {"port": 3, "state": "active", "id": 0x30}),
    ("type 30", "list_line", {"field": "type", "type": "30"}),
    ("  nmodes =5", "list_line", {"field": "nmodes", "value": 5}),
    ("  nview  =3", "list_line", {"field": "nview", "value": 3}),
    ("  baud   =115200", "list_line", {"field": "baud", "value": 115200}),
    ("  hwver  =00000004", "list_line", {"field": "hwver", "value": "00000004"}),
    ("  swver  =10000000", "list_line", {"field": "swver", "value": "10000000"}),
    ("  M0 POWER SI = PCT", "list_line", {"field": "mode", "mode": 0, "name": "POWER", "symbol": "PCT"}),
    ("  M1 SPEED SI = ", "list_line", {"field": "mode", "mode": 1, "symbol": ""}),
    ("    format count=1 type=0 chars=4 dp=0", "list_line",
     {"field": "format", "count": 1, "type_code": 0, "chars": 4, "dp": 0}),
    ("    RAW: 00000000 00000064    PCT: 00000000 00000064    SI: 00000000 00000064", "list_line",
     {"field": "range", "raw": (0, 100), "pct": (0, 100), "si": (0, 100)}),
    ("  C0: M1+M2+M3", "list_line", {"field": "combi", "index": 0, "modes": "M1+M2+M3"}),
    ("     speed PID: 00000BB8 00000064 00002328 00000438", "list_line",
     {"field": "speed_pid", "values": [0xBB8, 0x64, 0x2328, 0x438]}),
    ("  position PID: 00002EE0 000003E8 00013880 00000000", "list_line",
     {"field": "position_pid", "values": [0x2EE0, 0x3E8, 0x13880, 0]}),
    ("P1: connecting to active device", "connecting", {"port": 1}),
    ("set baud rate to 115200", "baud", {"baud": 115200}),
    ("P1: established serial communication with active ID 30", "established", {"port": 1, "id": 0x30}),
    ("P1: disconnected", "disconnected", {"port": 1}),
    ("P1: timeout during data phase: disconnecting", "timeout", {"port": 1, "phase": "data"}),
    ("P1: timeout during setup phase: disconnecting", "timeout", {"port": 1, "phase": "setup"}),
    ("P1: checksum error: disconnecting", "checksum_error", {"port": 1}),
    ("P1: too many errors (0+6): disconnecting", "too_many_errors", {"port": 1, "framing": 0, "checksum": 6}),
    ("P2: button pressed", "button", {"port": 2, "pressed": True}),
    ("P2: button released", "button", {"port": 2, "pressed": False}),
    ("P0: pulse done", "pulse_done", {"port": 0}),
    ("P3: ramp done", "ramp_done", {"port": 3}),
    ("Port power fault", "port_fault", {}),
    ("Motor power fault", "motor_fault", {}),
    (" Port 4D 4E 4F", "fault_dump", {"header": True}),
    ("   1  01 00 00", "fault_dump", {"port": 1, "flags": b"\x01\x00\x00"}),
    ("Error reading fault flags", "fault_read_error", {}),
    ("MQ overrun!", "mq_overrun", {}),
    ("deltat=0000000A", "deltat", {"ms": 10}),
    ("Type help <RETURN> for help", "banner", {"stage": "help_hint"}),
    ("Initialising ports", "banner", {"stage": "initialising"}),
    ("Resetting drivers: 0123", "banner", {"stage": "resetting"}),
    ("Reading driver dumps: before port_initdriver(): 0123", "banner", {"stage": "driver_dumps"}),
    ("Done initialising ports", "banner", {"stage": "done"}),
    ("Attempting reset of I²C bus", "i2c_error", {"error": "reset"}),
    ("Resetting drivers: 01<I²C bus timeout>23", "i2c_error",
     {"error": "I²C bus timeout", "before": "Resetting drivers: 01", "after": "23"}),
    ("P3M1: -5", "mode_data", {"port": 3, "mode": 1, "values": [-5]}),
    ("P3M0:  0", "mode_data", {"port": 3, "mode": 0, "values": [0]}),
    ("P3M2: +10000", "mode_data", {"port": 3, "mode": 2, "values": [10000]}),
    ("P3M4: +1 -1", "mode_data", {"port": 3, "mode": 4, "values": [1, -1]}),
    ("P3M6: 1.50000 -1.00000E-3 1.23457E8", "mode_data", {"values": [1.5, -1e-3, 1.23457e8]}),
    ("P3C0: +5 +360 -180", "combi_data", {"port": 3, "index": 0, "values": [5, 360, -180]}),
    ("P3V: -180.000", "var_data", {"port": 3, "value": -180.0}),
    ("P0V: 5.00000", "var_data", {"port": 0, "value": 5.0}),
    ("P0: pv=0.00000 sp=1.00000: e=-1.00000 ie=-0.0100000 de=-100.000 cv=15.0050", "pid_debug",
     {"port": 0, "pv": 0.0, "sp": 1.0, "e": -1.0, "ie": -0.01, "de": -100.0, "cv": 15.005}),
    ("P0: pv=0.995000 sp=1.00000: e=0.00000 ie=-0.0315000 de=50.0000 cv=-4.98425", "pid_debug",
     {"cv": -4.98425}),
    ("P1: DATA mode=2 payload=05 00 ff", "data_debug", {"port": 1, "mode": 2, "payload": b"\x05\x00\xff"}),
    ("P1: D5 signature=CCCC id=0", "signature_debug", {"port": 1, "signature": "CCCC", "id": "0"}),
    ("P1: type=80 cmd=12  payload=01 02", "unknown_debug", {"port": 1, "phase": "setup_info"}),
    ("P1 message type=44", "unknown_debug", {"port": 1, "phase": "setup"}),
    ("P1: data-phase message type 44 payload=00", "unknown_debug", {"port": 1, "phase": "data"}),
    ("Commands available:", "help", {}),
    ("  help, ?               : display this text", "help", {}),
    ("  help, ?              : display this text", "help", {}),
    ("  load <length> <checksum> : initiate upload", "help", {}),
    ("Firmware signature: 11 F4 E3 03", "signature", {"bytes": b"\x11\xf4\xe3\x03"}),
    ("Image too large (maximum 245760 bytes)", "bootloader_message", {"message": "too_large"}),
    ("Incorrect signature length (should be64 bytes)", "bootloader_message",
     {"message": "bad_signature_length"}),
    ("Image verifed OK", "bootloader_message", {"message": "verified"}),
    ("Verifying image length=54360 12 12 34 56", "bootloader_message", {"message": "verify_length"}),
    ("Rebooting...", "bootloader_message", {"message": "rebooting"}),
    (" 40 58 70 58", "hex_dump", {"bytes": b"\x40\x58\x70\x58"}),
    ("something the firmware never prints", "unknown", {}),
    ("error", "unknown", {}),             # case matters: only `Error` is the error line
    (" Error", "unknown", {}),
]


@pytest.mark.parametrize("line,kind,fields", FACTS_LINES, ids=[repr(x[0])[:40] for x in FACTS_LINES])
def test_classify_facts_lines(line, kind, fields):
    event = classify(line.encode("utf-8"))
    assert event.kind == kind, f"{line!r} -> {event.kind} {event.fields}"
    assert event.kind in KINDS
    for key, want in fields.items():
        assert event.fields.get(key) == want, f"{line!r}: {key}={event.fields.get(key)!r}, want {want!r}"
    assert event.raw == line.encode("utf-8")


def test_every_help_line_of_every_release_is_help():
    from buildhat_conformance.protocol.profiles import bootloader_data, load_profiles
    for p in load_profiles().values():
        for line in p.help_lines:
            if line:
                assert classify(line).kind == "help", (p.name, line)
    for line in bootloader_data()["help_text"]:
        assert classify(line).kind == "help", ("bootloader", line)


def test_parse_value_forms():
    assert parse_value("+5") == 5 and parse_value("-5") == -5 and parse_value("0") == 0
    assert isinstance(parse_value("+5"), int)
    assert parse_value("1.00000E6") == 1e6 and parse_value("2.77778E-3") == pytest.approx(2.77778e-3)
    assert parse_value("Inf") == math.inf and parse_value("-Inf") == -math.inf
    assert math.isnan(parse_value("NaN"))
    assert str(parse_value("-0.00000")) == "-0.0"


def test_non_utf8_line_keeps_raw_bytes():
    event = classify(b"P0M0: \xff\xfe")
    assert event.raw == b"P0M0: \xff\xfe"
    assert event.kind == "unknown"


def test_prompt_arrives_without_crlf_and_before_the_next_line():
    s = LineSplitter()
    assert s.feed(b"P", 0) == [] and s.partial == b"P"
    out = s.feed(b"0>", 1)
    assert [e.kind for e in out] == ["prompt"] and out[0].fields["port"] == 0
    # asynchronous output after a prompt starts on the same wire line
    out = s.feed(b"P2>P0M0: +5\r\n", 2)
    assert [(e.kind, e.text) for e in out] == [("prompt", "P2>"), ("mode_data", "P0M0: +5")]
    assert s.feed(b"\r\nType help <RETURN> for help\r\nBHBL", 3)[-1].kind == "banner"
    assert s.partial == b"BHBL"
    out = s.feed(b"> ", 4)
    assert [e.kind for e in out] == ["bootloader_prompt"] and s.partial == b""


def test_echo_and_blank_are_matched_to_host_lines():
    s = LineSplitter()
    first, = s.host_sent(b"vin\r")
    out = s.feed(b"\r\n7.20 V\r\n", 0)  # echo off: the CR's CRLF alone
    assert [(e.kind, e.fields.get("host_line")) for e in out] == [("blank", first), ("vin", None)]
    second, = s.host_sent(b"echo 1\r")
    third, = s.host_sent(b"port 1\r")
    out = s.feed(b"\r\nP0>port 1\r\nP1>", 1)  # FACTS §1: echo 1 then port 1 with echo on
    kinds = [(e.kind, e.fields.get("host_line")) for e in out]
    assert kinds == [("blank", second), ("prompt", None), ("echo", third), ("prompt", None)]
    # an edited line: the echo carries BS SP BS for every deleted byte
    fourth, = s.host_sent(b"vinx\x08\x08\r")
    out = s.feed(b"vinx\x08 \x08\x08 \x08\r\n7.20 V\r\nP1>", 2)
    assert out[0].kind == "echo" and out[0].fields["host_line"] == fourth
    assert out[1].kind == "vin"


def test_expected_echo_follows_the_line_editor():
    assert expected_echo(b"vinx\x08\x08") == b"vinx\x08 \x08\x08 \x08"
    assert expected_echo(b"\x08\x7fab") == b"ab"             # nothing to delete: nothing echoed
    assert expected_echo(b"x" * 300) == b"x" * 256           # the 256-byte buffer
    assert expected_echo(b"a\x7f") == b"a\x08 \x08"          # DEL acts as BS
