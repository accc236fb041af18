"""Commands with a direct answer on the wire: help, version, vin, port, ledmode, signature,
debug, and the `Error` rule (document §Command Summary; docs/FIRMWARE-BEHAVIOUR.md#fb-arguments,
#fb-commands)."""
from __future__ import annotations

import re

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import rejected, same
from ..needs import PortNeeds
from ..oracles.vin import adc_to_mv, vin_text
from ..verdict import Verdict


@pytest.mark.req("CMD-HELP")
@pytest.mark.parametrize("command", ["help", "?"])
def test_help_prints_the_synopsis_of_this_release(hat: HatUnderTest, command: str) -> None:
    raw = hat.exchange_quiet(command).raw
    text = raw.decode("utf-8")
    # Document: a synopsis of the available commands: every command of the table is named.
    missing = [c for c in hat.commands if not re.search(rf"(^|[\s,]){re.escape(c)}([\s,:]|$)", text,
                                                                  re.M)]
    assert not missing, f"help does not mention {missing}"
    # docs/FIRMWARE-BEHAVIOUR.md#fb-help: the exact text of this release.
    same(raw, b"\r\n" + hat.help_bytes, "this release's help text (docs/FIRMWARE-BEHAVIOUR.md#fb-help)",
         sent=command)


@pytest.mark.req("CMD-VERSION")
def test_version_prints_the_firmware_version(hat: HatUnderTest, verdict: Verdict) -> None:
    raw = hat.exchange_quiet("version").raw
    m = re.fullmatch(rb"\r\nFirmware version: ([0-9]+) (\S+)\r\n", raw)
    assert m, f"version answered {raw!r}"
    if hat.profile_exact and int(m.group(1)) == hat.profile.number:
        same(raw, b"\r\nFirmware version: " + hat.profile.version_string.encode() + b"\r\n",
             f"{hat.profile.name}'s version line (docs/FIRMWARE-BEHAVIOUR.md#fb-version)", sent="version")
    else:
        verdict.inform(f"version {m.group(1).decode()} is not a known release; judged as {hat.profile}")


@pytest.mark.req("CMD-VIN")
def test_vin_prints_volts_with_two_decimals(hat: HatUnderTest) -> None:
    raw = hat.exchange_quiet("vin").raw
    m = re.fullmatch(rb"\r\n([0-9]+)\.([0-9]{2}) V\r\n", raw)
    assert m, f"vin answered {raw!r}"
    volts = int(m.group(1)) + int(m.group(2)) / 100
    assert 0 <= volts <= 18.80, "the ADC cannot read more than 18805 mV (docs/FIRMWARE-BEHAVIOUR.md#fb-vin)"


def _adc_for(last_digit: int) -> int:
    """An ADC reading whose millivolts end in this digit (where vin's rounding shows)."""
    return next(a for a in range(1000, 4096) if adc_to_mv(a) % 10 == last_digit)


@pytest.mark.req("CMD-VIN", "FW-VIN-ROUNDING")
@pytest.mark.parametrize("adc", [0, 1742, _adc_for(4), _adc_for(5), _adc_for(6), _adc_for(9), 4095])
def test_vin_follows_the_supply_and_rounds_a_5_down(hat: HatUnderTest, world: PortNeeds, adc: int) -> None:
    world.require("adc", "control of the input voltage")
    try:
        world.action(f"@adc {adc}")
        hat.wait_ms(5)
        raw = hat.exchange_quiet("vin").raw
    finally:
        world.action("@adc 1742")
    mv = adc_to_mv(adc)
    assert raw == f"\r\n{vin_text(mv)}\r\n".encode(), f"ADC {adc} = {mv} mV"


def _port_line(hat: HatUnderTest, text: str) -> bytes:
    """What ``text`` printed with echo on, starting from port 2 (the prompt shows the port)."""
    hat.exchange("port 2")
    hat.exchange("echo 1")
    raw = hat.exchange(text).raw
    hat.exchange("echo 0")
    hat.exchange("port 0")
    return raw


@pytest.mark.req("CMD-PORT", "DEV-PORTS")
@pytest.mark.parametrize("text,port,error", [("port 0", 0, False), ("port 1", 1, False), ("port 2", 2, False),
                                             ("port 3", 3, False),
                                             ("port -1", 2, True), ("port 1x", 1, True),
                                             ("port 1.5", 1, True), ("port", 2, True)])
def test_port_sets_the_current_port(hat: HatUnderTest, text: str, port: int, error: bool) -> None:
    # A negative port is an Error and leaves the port (docs/FIRMWARE-BEHAVIOUR.md#fb-clamping,
    # #fb-doc-port-clamp).
    raw = _port_line(hat, text)
    expected = text.encode() + b"\r\n" + (b"Error\r\n" if error else b"") + f"P{port}>".encode()
    same(raw, expected, sent=text)


@pytest.mark.req("CMD-PORT", "FW-PORT-CLAMP")
@pytest.mark.parametrize("text", ["port 9", "port 4"])
def test_port_above_3_is_clamped_to_3(hat: HatUnderTest, text: str) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-clamping: `port <p>` clamps silently to 0..3, never an error.
    raw = _port_line(hat, text)
    assert raw == text.encode() + b"\r\nP3>", \
        (f"port clamping: `{text}` must select port 3 silently "
         f"(docs/FIRMWARE-BEHAVIOUR.md#fb-clamping); got {raw!r}")


@pytest.mark.req("DEV-PORTS", "CMD-LIST")
def test_four_ports_numbered_0_to_3(hat: HatUnderTest) -> None:
    lines = hat.exchange_quiet("list").list_lines()
    heads = [ln[:3] for ln in lines if re.match(r"P[0-9a-f]: ", ln)]
    assert heads == ["P0:", "P1:", "P2:", "P3:"], f"sent `list`: expected ports P0: to P3:, came {heads}"


@pytest.mark.req("CMD-LEDMODE")
@pytest.mark.parametrize("mode", ["-1", "0", "1", "2", "3", "7", "-5"])
def test_ledmode_accepts_its_values_silently(hat: HatUnderTest, verdict: Verdict, mode: str) -> None:
    raw = hat.exchange(f"ledmode {mode}").raw
    hat.exchange("ledmode -1")
    assert raw == b"\r\n", \
        "ledmode prints nothing (out-of-range values are clamped, docs/FIRMWARE-BEHAVIOUR.md#fb-clamping)"
    verdict.inform("the LED colours themselves are not observable on the command port")


@pytest.mark.req("CMD-LEDMODE", "FW-ERROR")
@pytest.mark.parametrize("line", ["ledmode", "ledmode x", "ledmode +-1"])
def test_ledmode_without_a_number_is_an_error(hat: HatUnderTest, line: str) -> None:
    rejected(hat.exchange(line))
    hat.exchange("ledmode -1")


@pytest.mark.req("CMD-SIGNATURE")
def test_signature_prints_64_bytes(hat: HatUnderTest) -> None:
    raw = hat.exchange_quiet("signature").raw
    m = re.fullmatch(rb"\r\nFirmware signature:((?: [0-9A-F]{2}){64})\r\n", raw)
    assert m, f"signature answered {raw!r}"
    if hat.profile_exact and hat.profile.signature is not None:
        assert bytes.fromhex(m.group(1).decode()) == hat.profile.signature, \
            f"sent `signature`: expected {hat.profile.name}'s signature " \
            f"(docs/FIRMWARE-BEHAVIOUR.md#fb-signature), came {raw!r}"


@pytest.mark.req("CMD-DEBUG")
@pytest.mark.parametrize("code", ["0", "2", "-0", "+2"])
def test_debug_accepts_a_code(hat: HatUnderTest, code: str) -> None:
    raw = hat.exchange(f"debug {code}").raw
    hat.exchange("debug 0")
    same(raw, b"\r\n", sent=f"debug {code}")


@pytest.mark.req("CMD-DEBUG", "FW-ERROR")
def test_debug_needs_its_code(hat: HatUnderTest) -> None:
    rejected(hat.exchange("debug"))


@pytest.mark.req("FW-ERROR")
@pytest.mark.parametrize("line", ["bogus", "vinx", "ports", "x", "-", "1", "versions", "helpme"])
def test_unknown_command_prints_exactly_error(hat: HatUnderTest, line: str) -> None:
    rejected(hat.exchange(line))


@pytest.mark.req("FW-ERROR", "LINK-PROMPT")
def test_error_with_echo_is_followed_by_the_prompt(hat: HatUnderTest) -> None:
    hat.exchange("echo 1")
    raw = hat.exchange("bogus").raw
    hat.exchange("echo 0")
    same(raw, b"bogus\r\nError\r\nP0>", sent="bogus")


@pytest.mark.req("FW-ERROR")
@pytest.mark.parametrize("command", ["help", "list", "vin", "version", "signature", "coast", "pwm", "on",
                                     "off", "clear_faults"])
def test_junk_after_a_command_that_cannot_fail(hat: HatUnderTest, command: str) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-errors, #fb-trailing: these never fail, but a following token is
    # a new command, so junk is an Error.
    lines = hat.exchange_quiet(f"{command} junk").lines
    assert lines[-1] == "Error" and lines.count("Error") == 1, \
        f"sent `{command} junk`: expected {command}'s answer, then one `Error` for `junk`; came {lines[-4:]}"
