"""The conformance suite's own oracles against the worked examples of FIRMWARE-FACTS."""
from __future__ import annotations

import pytest

from buildhat_conformance.conformance.oracles.commands import (
    ambiguous_prefixes,
    resolve,
    shortest_resolving_prefix,
    unique_prefix,
)
from buildhat_conformance.conformance.oracles.float32 import f32_bits
from buildhat_conformance.conformance.oracles.floatfmt import fw_float
from buildhat_conformance.conformance.oracles.listing import ListError, parse_list, render_active
from buildhat_conformance.conformance.oracles.numbers import parse_float, parse_hex_byte, parse_signed
from buildhat_conformance.conformance.oracles.pid import PidModel, Unwrapper
from buildhat_conformance.conformance.oracles.vin import adc_to_mv, vin_text
from buildhat_conformance.conformance.oracles.waveform import Generator, ticks_until_done
from buildhat_conformance.protocol.devices import catalogue
from buildhat_conformance.protocol.profiles import get_profile

# FIRMWARE-FACTS §6.3 step 7 and §6.1/§7.4 examples.
FLOATS = [(0, "0.00000"), (-0.0, "-0.00000"), (1, "1.00000"), (10, "10.0000"), (100, "100.000"),
          (90, "90.0000"), (-180, "-180.000"), (65535, "65535.0"), (3.14159265, "3.14159"), (0.1, "0.100000"),
          (0.001, "1.00000E-3"), (9.999999, "10.0000"), (999999.5, "1.00000E6"), (1234567, "1.23457E6"),
          (0.5, "0.500000"), (0.01, "0.0100000"), (1.23457e8, "1.23457E8"), (2.77778e-3, "2.77778E-3"),
          (1e-10, "1.00000E-10"), (1e30, "1.00000E30"), (123456.4, "123456"), (1.5, "1.50000"),
          (-1e-3, "-1.00000E-3"), (float("inf"), "Inf"), (float("-inf"), "-Inf"), (5, "5.00000")]


@pytest.mark.parametrize("value,text", FLOATS)
def test_float_printer(value: float, text: str) -> None:
    assert fw_float(value) == text


def test_number_parser_examples() -> None:
    assert f32_bits(parse_float("0.0027777778")[0]) == 0x3B360B61          # §3
    assert parse_float("1e3") == (1.0, 1)                                    # no exponent
    assert parse_float(".")[0] is None and parse_float("-.")[0] is None and parse_float("+")[0] is None
    assert str(parse_float("-0")[0]) == "-0.0"
    assert parse_signed("+-1")[0] is None and parse_signed("- 1")[0] is None and parse_signed("-5")[0] == -5
    assert parse_hex_byte("123")[0] == 0x23 and parse_hex_byte("fff")[0] == 0xFF
    assert parse_float("0.5 ")[1] == 4, "spaces after a number are skipped"


@pytest.mark.parametrize("mv,text", [(7200, "7.20 V"), (7205, "7.20 V"), (7206, "7.21 V"), (9999, "10.00 V"),
                                     (0, "0.00 V"), (18805, "18.80 V")])
def test_vin_rounding(mv: int, text: str) -> None:
    assert vin_text(mv) == text


def test_vin_adc_conversion() -> None:
    assert adc_to_mv(4095) == 18805 and vin_text(adc_to_mv(1742)) == "8.00 V"


# FIRMWARE-FACTS §2, "Shortest prefix that resolves to each command".
SHORTEST = {"R1": {"help": "h", "clear_faults": "c", "ledmode": "le", "coast": "co", "set": "s", "on": "on",
                   "bias": "b", "select": "sel", "selonce": "selo", "combi": "com", "write1": "w",
                   "write2": "write2", "version": "ve", "signature": "si", "vin": "v", "off": "o"},
            "R5": {"selrate": "selr", "select": "sel"},
            "R7": {"pid_diff": "pid_", "pwmparams": "pwmp", "port_plimit": "port_", "pid": "pi", "pwm": "pw"}}


@pytest.mark.parametrize("release", sorted(SHORTEST))
def test_shortest_prefixes_from_the_tables(release: str) -> None:
    table = get_profile(release).commands
    for name, prefix in SHORTEST[release].items():
        assert shortest_resolving_prefix(name, table) == prefix


def test_prefix_resolution_and_the_documents_rule() -> None:
    r1, r7 = get_profile("R1").commands, get_profile("R7").commands
    assert resolve("b", r7) is None and resolve("vinx", r1) is None and resolve("co", r1) == "coast"
    assert unique_prefix("coast", r1) == "coa" and unique_prefix("pid", r7) is None
    amb = {p: first for p, first, _names in ambiguous_prefixes(r1)}
    assert amb["c"] == "clear_faults" and amb["v"] == "vin" and amb["write"] == "write1" and "e" not in amb


def test_pid_example_sequence_of_facts_7_4() -> None:
    m = PidModel(5, parse_float("0.5")[0], parse_float("0.1")[0], 3, parse_float("0.01")[0])
    got = [" ".join(fw_float(x) for x in m.step(parse_float(pv)[0], 1.0))
           for pv in ("0", "0.1", "0.25", "0.5", "0.995")]
    assert got == ["-1.00000 -0.0100000 -100.000 15.0050", "-0.900000 -0.0190000 10.0000 3.50950",
                   "-0.750000 -0.0265000 15.0000 2.26325", "-0.500000 -0.0315000 25.0000 0.0157499",
                   "0.00000 -0.0315000 50.0000 -4.98425"]


def test_unwrapper_models() -> None:
    r7 = Unwrapper(1, 360, first_sample=True)
    assert [r7.sample(v) for v in (170, -170, 170)] == [170, 190, 170]
    r1 = Unwrapper(1, 360, first_sample=False)
    assert r1.sample(270) == -90, "R1-R5: the first value is the reading folded once from 0"


@pytest.mark.parametrize("period,ticks", [(0.1, 11), (0.2, 20), (0.5, 51), (1, 101), (2, 201), (3, 301),
                                          (5, 500), (10, 1000), (0.3, 30), (0.7, 71)])
def test_pulse_end_tick(period: float, ticks: int) -> None:
    assert ticks_until_done(parse_float(str(period))[0]) == ticks


def test_square_starts_at_min_and_ramp_phase() -> None:
    square = [v for v, _ in Generator("square", 0, 1, parse_float("0.2")[0], 0).run(20)]
    assert square[0] == 0 and square.count(0) in (9, 10, 11) and set(square) == {0, 1}, "starts at min"
    ramp = [v for v, _ in Generator("ramp", 0, 1, 1, 0.5).run(3)]
    assert ramp[0] > 0.5, "the ramp's phase shifts its start"


def test_list_renderer_reproduces_every_catalogue_block() -> None:
    for key, device in catalogue().items():
        if key.startswith("0x"):
            assert render_active(0, device) == device["hat_list_lines"], key


def test_list_grammar_accepts_a_dump_and_rejects_a_broken_one() -> None:
    good = render_active(0, catalogue()["0x30"]) + ["P1: no device detected", "P2: connected to passive ID 8",
                                                   "P3: no device detected"]
    assert [e.kind for e in parse_list(good)] == ["active", "empty", "passive", "empty"]
    for broken in (good[:-1], good + ["junk"], [good[0].replace("30", "31")] + good[1:],
                   [ln.rstrip() for ln in render_active(0, catalogue()["0x40"])] + good[-3:]):
        with pytest.raises(ListError):
            parse_list(broken)
