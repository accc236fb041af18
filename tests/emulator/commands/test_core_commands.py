"""Line editor, echo/prompt, dispatcher and core commands on the emulator (FIRMWARE-FACTS §1-§4,
Appendix A). Expected bytes are quoted from the facts, per profile they name."""
from __future__ import annotations

import pytest

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.protocol.profiles import load_profiles

EMPTY = {0: None, 1: None, 2: None, 3: None}
ALL = [p.name for p in load_profiles().values()]
# ADC reading that gives 7200 mV with §4.4's formula: ((1568*57)//10)*3300//4096 = 7200
ADC_7200 = 1568


def booted(firmware: str = "R7", adc: int = ADC_7200, **kw) -> Emulator:
    emu = Emulator(firmware=firmware, devices=EMPTY, **kw)
    emu.boot()
    emu.world(f"@adc {adc}")
    emu.advance(1)               # the firmware samples the ADC once per 1 ms tick (§4.4, §10)
    emu.read()
    return emu


def send(emu: Emulator, data: bytes) -> bytes:
    emu.write(data)
    emu.advance(1)
    return emu.read()


# -- Appendix A -----------------------------------------------------------------------------
def test_version_r7():
    assert send(booted("R7"), b"version\r") == \
        b"\r\nFirmware version: 1737564117 2025-01-22T16:41:57+00:00\r\n"


@pytest.mark.parametrize("name,text", [
    ("R1", "1630165527 2021-08-28T16:45:27+01:00"), ("R2", "1636109636 2021-11-05T10:53:56+00:00"),
    ("R3", "1643737936 2022-02-01T17:52:16+00:00"), ("R4", "1670332907 2022-12-06T13:21:47+00:00"),
    ("R5", "1670596313 2022-12-09T14:31:53+00:00"), ("R6", "1674818421 2023-01-27T11:20:21+00:00"),
    ("R7", "1737564117 2025-01-22T16:41:57+00:00")])
def test_version_every_release(name, text):      # §0 table, §4.1 `version`
    assert send(booted(name), b"version\r") == b"\r\nFirmware version: " + text.encode() + b"\r\n"


def test_version_string_override():
    emu = booted("R7", version_string="1737564117 custom")
    assert send(emu, b"version\r") == b"\r\nFirmware version: 1737564117 custom\r\n"


@pytest.mark.parametrize("name", ALL)
def test_vin_7200mv(name):
    assert send(booted(name), b"vin\r") == b"\r\n7.20 V\r\n"


def test_echo_then_port_then_clear_faults():
    emu = booted("R7")
    assert send(emu, b"echo 1\r") == b"\r\nP0>"
    assert send(emu, b"p 2\r") == b"p 2\r\nP2>"
    assert send(emu, b"c\r") == b"c\r\nP2>"          # clear_faults, no output


def test_crlf_from_host_starts_next_line_with_lf():
    emu = booted("R7")
    send(emu, b"echo 1\r")
    assert send(emu, b"port 1\r\nlist\r") == b"port 1\r\nP1>\nlist\r\nError\r\nP1>"


@pytest.mark.parametrize("name", ["R6", "R7"])
def test_hash_comment_ignored_r6_plus(name):
    emu = booted(name)
    send(emu, b"echo 1\r")
    assert send(emu, b"# comment\r") == b"# comment\r\n"


@pytest.mark.parametrize("name", ["R1", "R2", "R3", "R4", "R5"])
def test_hash_comment_is_error_before_r6(name):
    emu = booted(name)
    send(emu, b"echo 1\r")
    assert send(emu, b"# comment\r") == b"# comment\r\nError\r\nP0>"


def test_leading_space_defeats_hash_comment():
    assert send(booted("R7"), b" # x\r") == b"\r\nError\r\n"


def test_port_errors_and_clamps():
    emu = booted("R7")
    assert send(emu, b"port 1x\r") == b"\r\nError\r\n"
    assert emu.hat.port == 1
    assert send(emu, b"p -1\r") == b"\r\nError\r\n"
    assert emu.hat.port == 1
    assert send(emu, b"p 9\r") == b"\r\n"
    assert emu.hat.port == 3
    send(emu, b"port 1.5\r")
    assert emu.hat.port == 1


def test_bias_and_selrate_per_release():
    assert send(booted("R7"), b"bias .4\r") == b"\r\nError\r\n"
    assert send(booted("R5"), b"bias .4\r") == b"\r\n"
    assert send(booted("R4"), b"selr 5\r") == b"\r\nError\r\n"


# -- §1 line handling -----------------------------------------------------------------------
def test_cr_gives_crlf_with_echo_off():
    assert send(booted(), b"\r") == b"\r\n"


def test_lf_tab_and_case_are_not_separators():
    emu = booted()
    assert send(emu, b"vin\n\r") == b"\r\nError\r\n"
    assert send(emu, b"\tvin\r") == b"\r\nError\r\n"
    assert send(emu, b"VIN\r") == b"\r\nError\r\n"


def test_nul_hides_the_rest_of_the_line():
    assert send(booted(), b"vin\x00 junk\r") == b"\r\n7.20 V\r\n"


def test_bytes_above_0x7f_are_stored_and_echoed():
    emu = booted()
    send(emu, b"echo 1\r")
    assert send(emu, "vin\u00e9\r".encode()) == "vin\u00e9".encode() + b"\r\nError\r\nP0>"


def test_echo_example_r7():
    # §1 "Echo example, R7 (harness-verified)"
    emu = booted("R7")
    out = send(emu, b"echo 1\r") + send(emu, b"port 1\r") + send(emu, b"vinx\x08\x08\r")
    assert out == b"\r\nP0>" + b"port 1\r\nP1>" + b"vinx" + b"\b \b\b \b" + b"\r\n7.20 V\r\nP1>"


def test_rubout_on_empty_buffer_does_nothing_and_del_works():
    emu = booted()
    send(emu, b"echo 1\r")
    assert send(emu, b"\x08\x7f") == b""
    assert send(emu, b"vx\x7f\r") == b"vx\b \b\r\n7.20 V\r\nP0>"


def test_rubout_without_echo_is_silent():
    assert send(booted(), b"vinx\x08\r") == b"\r\n7.20 V\r\n"


def test_echo_0_line_has_no_prompt():
    emu = booted()
    send(emu, b"echo 1\r")
    assert send(emu, b"echo 0\r") == b"echo 0\r\n"
    assert send(emu, b"echo 5\r") == b"\r\nP0>"        # any non-zero value enables it


def test_prompt_after_empty_and_error_lines():
    emu = booted()
    send(emu, b"echo 1\r")
    assert send(emu, b"\r") == b"\r\nP0>"
    assert send(emu, b"zz\r") == b"zz\r\nError\r\nP0>"


def test_line_buffer_256_bytes():
    emu = booted()
    send(emu, b"echo 1\r")
    line = b"vin" + b" " * 253            # 256 bytes: fills the buffer
    out = send(emu, line + b"xyz\r")      # the excess is dropped silently and not echoed
    assert out == line + b"\r\n7.20 V\r\nP0>"


def test_commands_need_no_semicolon_and_errors_keep_earlier_effects():
    emu = booted()
    assert send(emu, b"port 1 vin\r") == b"\r\n7.20 V\r\n"
    assert emu.hat.port == 1
    assert send(emu, b"port 2;zz;port 3\r") == b"\r\nError\r\n"
    assert emu.hat.port == 2                       # earlier effect kept, rest dropped
    assert send(emu, b"port;1;;vin\r") == b"\r\n7.20 V\r\n"
    assert emu.hat.port == 1


def test_junk_after_commands_that_cannot_fail():
    assert send(booted(), b"vin x\r") == b"\r\n7.20 V\r\nError\r\n"
    assert send(booted(), b"vinx\r") == b"\r\nError\r\n"
    assert send(booted(), b"e\r") == b"\r\nError\r\n"    # echo without its argument


# -- §4 core commands -----------------------------------------------------------------------
@pytest.mark.parametrize("adc,text", [(1742, b"8.00 V"), (4095, b"18.80 V"), (0, b"0.00 V")])
def test_vin_from_adc(adc, text):
    # SCENARIO-SCRIPT: 1742 -> 8.00 V; §4.4: ADC 4095 is 18805 mV -> 18.80 V
    assert send(booted(adc=adc), b"vin\r") == b"\r\n" + text + b"\r\n"


def test_vin_rounding_rule():
    from buildhat_conformance.emulator.commands.core_commands import format_vin
    for mv, text in [(7200, "7.20 V"), (7205, "7.20 V"), (7206, "7.21 V"), (9999, "10.00 V"),
                     (0, "0.00 V"), (18805, "18.80 V")]:
        assert format_vin(mv) == text


def test_help_lengths_per_release():
    # §4.3: R6-R7 4201 bytes / 67 lines, R1-R4 4136 / 67, R5 4293 / 69 (plus the CR's CRLF)
    for name, size, lines in [("R1", 4136, 67), ("R4", 4136, 67), ("R5", 4293, 69), ("R7", 4201, 67)]:
        out = send(booted(name), b"help\r")
        assert out[:2] == b"\r\n"
        assert len(out) - 2 == size and out[2:].count(b"\r\n") == lines, name
        assert out.startswith(b"\r\nCommands available:\r\n")
    r7 = send(booted("R7"), b"?\r")
    assert r7.endswith(b"8=DATA payload; 16=PID controller; 32=unknown messages\r\n")
    assert "<ledmode>             : 0=off 1=orange 2=green 3=orange+green \u20131=monitor Vin".encode() in r7


def test_signature_r7_and_prefixes():
    r7 = ("Firmware signature: 11 F4 E3 03 4E D4 2E 32 9A 77 53 6D 19 17 A2 51 2F 49 A6 D3 8D 6D EF 0D 29 69 "
          "6F 5C 81 7E A6 9F 49 99 41 7A 34 92 16 C4 98 C9 85 F1 50 DF E3 BC 77 EA 3E 5C 77 19 0D 1C A1 98 "
          "0E 4C F2 9F 56 99")
    assert send(booted("R7"), b"signature\r") == b"\r\n" + r7.encode() + b"\r\n"
    assert send(booted("R1"), b"si\r").startswith(b"\r\nFirmware signature: 1F E0 63 B3 03 1B 36 C3")
    assert send(booted("R2"), b"si\r").startswith(b"\r\nFirmware signature: 1E B0 13 3B 10 0D 83 3E")


def test_signature_r4_unknown_is_noted():
    emu = booted("R4")
    out = send(emu, b"signature\r")
    assert out.startswith(b"\r\nFirmware signature:") and len(out) == 2 + 19 + 64 * 3 + 2
    assert any(e["dir"] == "note" and "unknown" in e["text"] for e in emu.events)


def test_ledmode_clamps_and_led_events():
    emu = booted("R7", adc=1742)                  # 7999 mV: ledmode -1 shows code 2 (green)
    assert emu.hat.leds == 2
    send(emu, b"ledmode 5\r")
    assert emu.hat.ledmode == 3 and emu.hat.leds == 3
    send(emu, b"ledmode -7\r")
    assert emu.hat.ledmode == -1
    emu.world("@adc 4095")                        # 18805 mV -> code 1
    emu.advance(2)
    assert emu.hat.leds == 1
    emu.world("@adc 800")                         # below 4800 mV: off
    emu.advance(2)
    assert emu.hat.leds == 0
    led = [e["value"] for e in emu.events if e["dir"] == "led"]
    assert led == [2, 3, 2, 1, 0]
    assert send(emu, b"ledmode\r") == b"\r\nError\r\n"


def test_echo_and_debug_store_32_bit_values():
    emu = booted()
    send(emu, b"debug -5\r")
    assert emu.hat.debug == -5
    send(emu, b"echo 4294967295\r")
    assert emu.hat.echo == -1


# -- Appendix A vectors whose output is the dispatcher's (Error / nothing), per profile -------------
def test_list_on_empty_hat():
    assert send(booted("R7"), b"list\r") == (b"\r\nP0: no device detected\r\nP1: no device detected\r\n"
                                             b"P2: no device detected\r\nP3: no device detected\r\n")


@pytest.mark.parametrize("name", ALL)
def test_document_pid_vectors(name):
    ten = b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3\r"
    eleven = b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3 0.01\r"
    r6_plus = name in ("R6", "R7")
    assert send(booted(name), ten) == (b"\r\nError\r\n" if r6_plus else b"\r\n")
    assert send(booted(name), eleven) == (b"\r\n" if r6_plus else b"\r\nError\r\n")


@pytest.mark.parametrize("line", [b"set t 0 1 1e3 0\r", b"write1 0x12\r", b"select 0 5\r",
                                  b"list 0\r", b"set sine0 0 1 1 0\r", b"set pulse 1 0 2\r"])
def test_appendix_a_error_lines(line):
    assert send(booted("R7"), line).endswith(b"Error\r\n")
