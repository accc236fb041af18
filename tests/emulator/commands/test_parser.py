"""Number parsers and the command matcher (FIRMWARE-FACTS §2, §3). Expectations quote the facts."""
from __future__ import annotations

import struct

import pytest

from buildhat_conformance.emulator.commands.parser import CommandError, Cursor
from buildhat_conformance.protocol.profiles import get_profile


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


def f32_hex(x: float) -> int:
    return struct.unpack("<I", struct.pack("<f", x))[0]


# -- §2 matcher --------------------------------------------------------------------------
# "Shortest prefix that resolves to each command" table, per profile group.
SHORTEST = {
    "R1": {"help": "h", "?": "?", "clear_faults": "c", "port": "p", "list": "l", "ledmode": "le",
           "pwm": "pw", "coast": "co", "pid": "pi", "set": "s", "off": "o", "on": "on", "vin": "v",
           "bias": "b", "plimit": "pl", "select": "sel", "selonce": "selo", "combi": "com",
           "write1": "w", "write2": "write2", "echo": "e", "debug": "d", "version": "ve",
           "signature": "si"},
}
SHORTEST["R4"] = SHORTEST["R1"]
SHORTEST["R5"] = dict(SHORTEST["R1"], selrate="selr")
SHORTEST["R7"] = dict(SHORTEST["R5"], pid_diff="pid_", pwmparams="pwmp", port_plimit="port_")
del SHORTEST["R7"]["bias"]
SHORTEST["R6"] = SHORTEST["R7"]


def resolve(profile_name: str, text: bytes):
    cur = Cursor(text)
    return cur.match(get_profile(profile_name).commands), cur


@pytest.mark.parametrize("profile", sorted(SHORTEST))
def test_shortest_prefixes_resolve(profile):
    for name, prefix in SHORTEST[profile].items():
        assert resolve(profile, prefix.encode())[0] == name, (profile, prefix)
        # and the full name resolves to itself
        assert resolve(profile, name.encode())[0] == name, (profile, name)


@pytest.mark.parametrize("text,expected", [
    (b"c", "clear_faults"), (b"co", "coast"), (b"l", "list"), (b"o", "off"), (b"p", "port"),
    (b"s", "set"), (b"se", "set"), (b"sel", "select"), (b"sele", "select"), (b"v", "vin"),
    (b"w", "write1"), (b"wr", "write1"), (b"wri", "write1"), (b"writ", "write1"),
    (b"write", "write1"), (b"e", "echo"), (b"d", "debug"),
    # R6+: po/por/port -> port, pw/pwm -> pwm, pi/pid -> pid
    (b"po", "port"), (b"por", "port"), (b"pwm", "pwm"), (b"pid", "pid"),
])
def test_ambiguous_prefixes_r7(text, expected):
    assert resolve("R7", text)[0] == expected


@pytest.mark.parametrize("text", [b"ports", b"pid_diffx", b"vinx", b"VIN", b"\tvin", b"\nvin", b"b"])
def test_tokens_that_match_nothing_r7(text):
    assert resolve("R7", text)[0] is None


def test_bias_only_before_r6_and_selrate_from_r5():
    assert resolve("R5", b"b")[0] == "bias"
    assert resolve("R4", b"selr")[0] is None
    assert resolve("R5", b"selr")[0] == "selrate"


def test_one_separator_then_spaces_consumed():
    name, cur = resolve("R7", b"port;2")
    assert name == "port" and cur.rest() == b"2"
    name, cur = resolve("R7", b"set;0.25")
    assert name == "set" and cur.rest() == b"0.25"
    name, cur = resolve("R7", b"port    2")
    assert name == "port" and cur.rest() == b"2"
    # only one ';' is consumed: the second one is left for the argument parser
    name, cur = resolve("R7", b"port;;2")
    assert cur.rest() == b";2"


def test_set_keywords_r7_and_r1():
    kw7 = get_profile("R7").set_keywords
    for text, want in [(b"s", "square"), (b"sq", "square"), (b"si", "sine"), (b"t", "triangle"),
                       (b"p", "pulse"), (b"r", "ramp"), (b"v", "var")]:
        assert Cursor(text).match(kw7) == want
    assert Cursor(b"v").match(get_profile("R1").set_keywords) is None
    assert Cursor(b"sine0 1").match(kw7) is None       # `set sine0 …` -> Error


def test_nul_ends_the_line():
    cur = Cursor(b"vin\x00junk")
    assert cur.data == b"vin"


# -- §3 numbers --------------------------------------------------------------------------
def test_unsigned_wraps_and_stops_at_non_digit():
    assert Cursor(b"4294967297").unsigned() == 1
    cur = Cursor(b"1x")
    assert cur.unsigned() == 1 and cur.rest() == b"x"
    cur = Cursor(b"1.5")
    assert cur.unsigned() == 1 and cur.rest() == b".5"
    for bad in (b"-1", b"+1", b"", b"x"):
        with pytest.raises(CommandError):
            Cursor(bad).unsigned()


def test_number_parsers_skip_spaces_not_semicolons():
    cur = Cursor(b"1   ;2")
    assert cur.unsigned() == 1 and cur.rest() == b";2"


def test_signed():
    assert Cursor(b"-1").signed() == -1
    assert Cursor(b"+7").signed() == 7
    assert Cursor(b"4294967295").signed() == -1        # 32-bit result
    assert Cursor(b"-2147483648").signed() == -2147483648
    for bad in (b"+-1", b"- 1", b"-", b"+", b""):
        cur = Cursor(bad)
        with pytest.raises(CommandError):
            cur.signed()
        assert cur.pos == 0
    assert Cursor(b"- 1").try_signed() is None


def test_float_syntaxes():
    assert Cursor(b".5").float() == 0.5
    assert Cursor(b"5.").float() == 5.0
    assert Cursor(b"+3").float() == 3.0
    neg_zero = Cursor(b"-0").float()
    assert neg_zero == 0.0 and struct.pack("<f", neg_zero)[3] == 0x80   # −0.0
    for bad in (b".", b"-.", b"+", b"", b"e3"):
        with pytest.raises(CommandError):
            Cursor(bad).float()


def test_float_has_no_exponent():
    cur = Cursor(b"1e3")
    assert cur.float() == 1.0 and cur.rest() == b"e3"


def test_float_single_precision_vector():
    # §3: `0.0027777778` -> 0.00277777785 (0x3B360B61)
    assert f32_hex(Cursor(b"0.0027777778").float()) == 0x3B360B61


def test_float_nine_digit_accumulator():
    # at most 9 significant digits: later fraction digits are ignored, later integer digits scale
    assert Cursor(b"1.23456789999").float() == Cursor(b"1.23456789").float()
    # (float)123456789 x 10 in single precision
    assert Cursor(b"1234567890").float() == f32(f32(123456789.0) * 10.0)
    # leading zeros count towards f but not towards the 9-digit limit: 123456789 / 10^12
    assert Cursor(b"0.000123456789").float() == f32(123456789.0 / 1e12)
    assert Cursor(b"0.0001234567899").float() == f32(123456789.0 / 1e12)


def test_hex_bytes():
    assert Cursor(b"123").hexbyte() == 0x23
    assert Cursor(b"fff").hexbyte() == 0xFF
    assert Cursor(b"FFFFFFFF").hex32() == 0xFFFFFFFF
    assert Cursor(b"1FFFFFFFF").hex32() == 0xFFFFFFFF       # wraps modulo 2^32
    cur = Cursor(b"0x12")
    assert cur.hexbyte() == 0 and cur.rest() == b"x12"
    with pytest.raises(CommandError):
        Cursor(b"x1").hexbyte()


def test_format_specifier():
    codes = {b"u1": 0x001, b"s1": 0x101, b"u2": 0x002, b"s2": 0x102, b"u4": 0x004, b"s4": 0x104,
             b"f4": 0x204}
    for text, code in codes.items():
        assert Cursor(text).format() == code
    cur = Cursor(b"u1x")          # `u1x` = `u1` followed by the token `x`
    assert cur.format() == 0x001 and cur.rest() == b"x"
    for bad in (b"u3", b"f2", b"u", b""):
        with pytest.raises(CommandError):
            Cursor(bad).format()
