"""The suite's number parsers (conformance/oracles/numbers.py) against the worked examples of
FIRMWARE-FACTS."""
from __future__ import annotations

from buildhat_conformance.conformance.oracles.float32 import f32_bits
from buildhat_conformance.conformance.oracles.numbers import parse_float, parse_hex_byte, parse_signed


def test_number_parser_examples() -> None:
    value = parse_float("0.0027777778")[0]
    assert value is not None and f32_bits(value) == 0x3B360B61           # §3
    assert parse_float("1e3") == (1.0, 1)                                    # no exponent
    assert parse_float(".")[0] is None and parse_float("-.")[0] is None and parse_float("+")[0] is None
    assert str(parse_float("-0")[0]) == "-0.0"
    assert parse_signed("+-1")[0] is None and parse_signed("- 1")[0] is None and parse_signed("-5")[0] == -5
    assert parse_hex_byte("123")[0] == 0x23 and parse_hex_byte("fff")[0] == 0xFF
    assert parse_float("0.5 ")[1] == 4, "spaces after a number are skipped"
