"""The model's line parsing (fuzz/model/line_parsing.py) against docs/FIRMWARE-BEHAVIOUR.md#fb-matching (first
name in table order that starts with the word) and #fb-numbers (decimals: at most 9 significant digits,
single precision; Q16 storage)."""
from __future__ import annotations

import struct

import pytest

from buildhat_conformance.fuzz.model.line_parsing import float_value, prefix_table, q16
from buildhat_conformance.protocol.profiles import get_profile


def _bits(x: float) -> int:
    return struct.unpack("<I", struct.pack("<f", x))[0]


@pytest.mark.parametrize("word,name", [(b"v", "vin"), (b"ve", "version"), (b"p", "port"), (b"pi", "pid"),
                                       (b"pid_", "pid_diff"), (b"s", "set"), (b"sel", "select"),
                                       (b"selr", "selrate"), (b"?", "?"), (b"h", "help")])
def test_a_word_means_the_first_command_in_table_order_it_starts(word, name):
    assert prefix_table(tuple(get_profile("R7").commands))[word] == name


@pytest.mark.parametrize("word", [b"ports", b"vinx", b"pid_diffx", b"VIN", b"bias", b""])
def test_longer_words_other_case_and_other_releases_match_nothing(word):
    assert word not in prefix_table(tuple(get_profile("R7").commands))


def test_the_documents_long_fraction():
    # fb-numbers: `0.0027777778` becomes 0.00277777785 (0x3B360B61).
    assert _bits(float_value(b"0", b"0027777778")) == 0x3B360B61


@pytest.mark.parametrize("whole,fraction,value", [
    (b"1", b"5", 1.5), (b"", b"25", 0.25), (b"7", b"", 7.0),
    (b"1234567890", b"", 1234567890.0),       # 9 digits kept, the 10th scales by 10: 123456789 x 10
    (b"123456789", b"99", 123456789.0),       # fraction digits past the ninth are dropped
])
def test_at_most_nine_significant_digits_count(whole, fraction, value):
    assert float_value(whole, fraction) == struct.unpack("<f", struct.pack("<f", value))[0]


@pytest.mark.parametrize("x,stored", [(0.5, 32768), (1.0, 65536), (2.0, 65536), (-1.0, 0), (0.3, 19661)])
def test_q16_clamps_to_0_1_then_rounds(x, stored):
    # fb-numbers / fb-pwm-path: clamp to [0, 1], then floor(x * 65536 + 0.5); 0.3 * 65536 = 19660.8.
    assert q16(x) == stored
