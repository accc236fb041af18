"""FIRMWARE-FACTS §1 (line handling), §2 (command matching) and §3 (tokens, numbers, errors,
clamping) as vector tables, run on the wire for every profile each vector names.

Every expected byte string is quoted from (or spelled out by) FIRMWARE-FACTS; the section is
given on each row. Vectors that an existing test already covers exactly, for every profile
they name, are not repeated here: tests/FACTS-COVERAGE.md lists where they are.
Where a vector has no output of its own (``port 2``, ``c``), the row also checks the state the
facts say it changes, right after the line (before any 10 ms update or empty-port reset).
"""
from __future__ import annotations

import re
import struct
from typing import Dict, List, Optional

import behaviour_doc
import pytest

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.protocol.profiles import load_profiles

EMPTY = {0: None, 1: None, 2: None, 3: None}
ALL = [p.name for p in load_profiles().values()]
pytestmark = pytest.mark.req("FW-1", "FW-2", "FW-3", "FW-4.3")
R1_R5 = ["R1", "R2", "R3", "R4", "R5"]
R6_R7 = ["R6", "R7"]
# ((1568*57)//10)*3300//4096 = 7200 mV (§4.4 formula) -> `7.20 V`
ADC_7200 = 1568
VIN = b"\r\n7.20 V\r\n"
ERR = b"\r\nError\r\n"


def f32_bits(x: float) -> int:
    return struct.unpack("<I", struct.pack("<f", x))[0]


class Hat:
    """A booted empty HAT (7.20 V) with the wire and the resolved commands of each line."""

    def __init__(self, profile: str, echo: bool = False):
        self.emu = Emulator(firmware=profile, devices=EMPTY)
        self.emu.boot()
        self.emu.world(f"@adc {ADC_7200}")
        self.emu.advance(1)      # the ADC is sampled once per 1 ms tick (§4.4, §10)
        self.records: List = []
        self.emu.hat.line_observers.append(self.records.append)
        if echo:
            self.send(b"echo 1\r")
        self.emu.read()
        self.records.clear()

    @property
    def hat(self):
        return self.emu.hat

    def send(self, data: bytes) -> bytes:
        """Bytes in, everything the firmware wrote for them out (no time passes)."""
        self.emu.write(data)
        return self.emu.read()

    def ran(self) -> List[str]:
        return [name for r in self.records for name in r.commands]


# =====================================================================================
# §1 line handling ("all versions unless noted")
# =====================================================================================
# (section, echo, input, expected wire bytes)
LINE_VECTORS = [
    ("§1 CR -> CRLF with echo off", False, b"\r", b"\r\n"),
    ("§2 leading spaces and `;` are skipped", False, b" ;; ; vin\r", VIN),
    ("§2 a line of separators is empty", False, b";; ;\r", b"\r\n"),
    ("§1 `vin\\n⏎` -> Error (LF is stored)", False, b"vin\n\r", ERR),
    ("§1 host CRLF: next line starts with LF", False, b"vin\r\nvin\r", VIN + ERR),
    ("§1 `\\tvin⏎` -> Error", False, b"\tvin\r", ERR),
    ("§1 NUL ends the line", False, b"vin\x00 junk\r", VIN),
    ("§1 bytes >= 0x80 stored", False, b"vin\xc3\xa9\r", ERR),
    ("§1 `VIN⏎` -> Error", False, b"VIN\r", ERR),
    ("§1 BS removes the last byte, echo 08 20 08", True, b"vinx\x08\r", b"vinx\x08 \x08" + VIN + b"P0>"),
    ("§1 DEL removes the last byte, echo 08 20 08", True, b"vinx\x7f\r", b"vinx\x08 \x08" + VIN + b"P0>"),
    ("§1 BS/DEL on an empty buffer: nothing", True, b"\x08\x7f\x08\r", b"\r\nP0>"),
    ("§1 BS without echo is silent", False, b"vinx\x08\r", VIN),
    ("§1 stored bytes are echoed, >= 0x80 too", True, b"vin\xe9\r", b"vin\xe9" + ERR + b"P0>"),
    ("§1 256-byte buffer, excess dropped, not echoed", True,
     b"vin" + b" " * 253 + b"xyz\r", b"vin" + b" " * 253 + VIN + b"P0>"),
    ("§1 ` # x⏎` -> Error (leading space)", False, b" # x\r", ERR),
    ("§1 `echo 1⏎` typed with echo off -> `\\r\\nP0>`", False, b"echo 1\r", b"\r\nP0>"),
    ("§1 `echo 0⏎` -> just CRLF (echo was on)", True, b"echo 0\r", b"echo 0\r\n"),
    ("§1 any non-zero echo enables the prompt", False, b"echo -7\r", b"\r\nP0>"),
    ("§1 prompt after an empty line", True, b"\r", b"\r\nP0>"),
    ("§1 prompt after an Error line", True, b"zz\r", b"zz" + ERR + b"P0>"),
    ("§1 prompt shows the port at the end of the line", True, b"port 2\r", b"port 2\r\nP2>"),
]


@pytest.mark.parametrize("section,echo,data,expected", LINE_VECTORS, ids=[v[0] for v in LINE_VECTORS])
def test_line_handling_vectors(section, echo, data, expected):
    for profile in ALL:
        assert Hat(profile, echo=echo).send(data) == expected, profile


def test_no_prompt_ever_at_startup():
    # §1 "echo is 0 at boot, so no prompt is ever sent at startup" (and §5's banner order)
    for profile in ALL:
        emu = Emulator(firmware=profile, devices=EMPTY)
        emu.boot()
        assert emu.read() == (b"\r\nType help <RETURN> for help\r\nInitialising ports\r\n"
                              b"Resetting drivers: 0123\r\n"
                              b"Reading driver dumps: before port_initdriver(): 0123\r\n"
                              b"Reading driver dumps: after port_initdriver(): 0123\r\n"
                              b"Done initialising ports\r\n"), profile


# =====================================================================================
# §2 command matching
# =====================================================================================
def _pid_args(profile: str) -> bytes:
    # svar 0 0 0 u1 scale 1 unwrap 0, Kp 1 Ki 0 Kd 0 windup 0 (+ deadzone 0 on R6+: 11 numbers)
    eleven = profile in R6_R7
    return b" 0 0 0 u1 1 0 1 0 0 0" + (b" 0" if eleven else b"")


def _args(name: str, profile: str) -> bytes:
    """Arguments that make ``name`` succeed (§3/§4.1 syntax) on an empty HAT."""
    return {
        "port": b" 2", "ledmode": b" 2", "pid": _pid_args(profile), "pid_diff": _pid_args(profile),
        "set": b" 0.5", "bias": b" 0.4", "pwmparams": b" 0 0", "plimit": b" 0.5",
        "port_plimit": b" 0.5", "select": b" 1", "selonce": b" 1", "selrate": b" 5", "combi": b" 0",
        "write1": b" 40", "write2": b" 44 11", "echo": b" 0", "debug": b" 0",
    }.get(name, b"")


def _output(name: str, profile: str, help_texts) -> Optional[bytes]:
    """What the command prints after the CR's CRLF (None: checked by pattern instead)."""
    if name in ("help", "?"):
        return b"\r\n" + help_texts[profile]
    if name == "vin":
        return VIN
    if name == "list":
        return b"\r\n" + b"".join(b"P%d: no device detected\r\n" % p for p in range(4))
    if name == "version":
        vs = load_profiles_by_name()[profile].version_string.encode()
        return b"\r\nFirmware version: " + vs + b"\r\n"
    if name == "signature":
        return None
    return b"\r\n"


def load_profiles_by_name():
    return {p.name: p for p in load_profiles().values()}


def _check(h: Hat, out: bytes, name: str, profile: str, help_texts) -> None:
    expected = _output(name, profile, help_texts)
    if expected is None:      # §4.1: `Firmware signature:` + 64 x (space + 2 upper-case hex)
        assert re.fullmatch(rb"\r\nFirmware signature:( [0-9A-F]{2}){64}\r\n", out), out
    else:
        assert out == expected
    assert h.ran() == [name]


@pytest.fixture(scope="module")
def behaviour_text() -> str:
    # The project's account of the facts (docs/FIRMWARE-BEHAVIOUR.md); tests/protocol/test_behaviour.py
    # checks its help texts and prefix table against the original facts where ../shared exists.
    return behaviour_doc.text()


@pytest.fixture(scope="module")
def help_texts(behaviour_text) -> Dict[str, bytes]:
    """The help text of each profile as wire bytes (every line CRLF)."""
    texts = behaviour_doc.help_lines(behaviour_text)
    out = {}
    for name in ALL:
        key = "R6-R7" if name in R6_R7 else ("R5" if name == "R5" else "R1-R4")
        out[name] = "".join(x + "\r\n" for x in texts[key]).encode("utf-8")
    return out


COLUMNS = {"R1": 0, "R2": 0, "R3": 0, "R4": 0, "R5": 1, "R6": 2, "R7": 2}


@pytest.fixture(scope="module")
def shortest(behaviour_text):
    rows = behaviour_doc.shortest_table(behaviour_text)
    assert len(rows) == 28, sorted(rows)     # 28 rows in the facts table (help ... signature)
    return rows


@pytest.mark.parametrize("profile", ALL)
def test_every_shortest_prefix_row_on_the_wire(profile, shortest, help_texts):
    # §2 "Shortest prefix that resolves to each command", this profile's column.
    checked = 0
    for name, cells in shortest.items():
        cell = cells[COLUMNS[profile]]
        m = re.match(r"`([^`]+)`", cell)
        if m is None:                       # `—`: the command does not exist in this release
            assert cell.startswith("—"), (name, cell)
            assert name not in load_profiles_by_name()[profile].commands
            h = Hat(profile)
            out = h.send(name.encode() + _args(name, profile) + b"\r")
            assert out == ERR, (profile, name)
            continue
        prefix = m.group(1).encode()
        h = Hat(profile)
        out = h.send(prefix + _args(name, profile) + b"\r")
        _check(h, out, name, profile, help_texts)
        if len(prefix) > 1:                 # "shortest": one byte less is something else
            h = Hat(profile)
            h.send(prefix[:-1] + _args(name, profile) + b"\r")
            assert name not in h.ran(), (profile, name, prefix[:-1])
        checked += 1
    assert checked == len(load_profiles_by_name()[profile].commands)


@pytest.mark.parametrize("profile", R6_R7)
def test_b_prefix_is_an_error_r6_plus(profile):
    # §2 table: bias R6–R7 "— (`b…` → `Error`)"
    for text in (b"b\r", b"b .4\r", b"bi .4\r"):
        assert Hat(profile).send(text) == ERR


# §2 "Ambiguous prefixes and what they resolve to (all versions unless marked)"
AMBIGUOUS = [
    (b"c", "clear_faults", ALL), (b"co", "coast", ALL), (b"l", "list", ALL), (b"o", "off", ALL),
    (b"p", "port", ALL), (b"po", "port", R6_R7), (b"por", "port", R6_R7), (b"port", "port", R6_R7),
    (b"pw", "pwm", R6_R7), (b"pwm", "pwm", R6_R7), (b"pi", "pid", R6_R7), (b"pid", "pid", R6_R7),
    (b"s", "set", ALL), (b"se", "set", ALL), (b"sel", "select", ALL), (b"sele", "select", ALL),
    (b"sel", "select", ["R5", "R6", "R7"]), (b"v", "vin", ALL), (b"w", "write1", ALL),
    (b"wr", "write1", ALL), (b"wri", "write1", ALL), (b"writ", "write1", ALL),
    (b"write", "write1", ALL), (b"e", "echo", ALL), (b"d", "debug", ALL),
]


@pytest.mark.parametrize("prefix,name,profiles", AMBIGUOUS,
                         ids=[f"{p.decode()}->{n}" for p, n, _ in AMBIGUOUS])
def test_ambiguous_prefixes_on_the_wire(prefix, name, profiles, help_texts):
    for profile in profiles:
        h = Hat(profile)
        _check(h, h.send(prefix + _args(name, profile) + b"\r"), name, profile, help_texts)


def test_bare_e_is_echo_without_argument():
    # §2: "A bare `e⏎` is `echo` without its argument → `Error`."
    for profile in ALL:
        h = Hat(profile)
        assert h.send(b"e\r") == ERR and h.ran() == ["echo"], profile


def test_longer_tokens_and_unknown_names_are_errors():
    # §2: "A token longer than the name never matches it, so `ports`, `pid_diffx` and `vinx` → Error"
    for profile in ALL:
        for token in (b"ports", b"pid_diffx", b"vinx", b"write3", b"x"):
            h = Hat(profile)
            assert h.send(token + b"\r") == ERR and h.ran() == [], (profile, token)


@pytest.mark.parametrize("profile", ALL)
def test_one_separator_after_the_name(profile):
    # §2 "`set;0.25` = `set 0.25` and `port;2` = `port 2` (harness-verified)"
    h = Hat(profile)
    assert h.send(b"set;0.25\r") == b"\r\n"
    assert h.hat.controllers[0].generator.a == 0.25
    assert h.send(b"port;2\r") == b"\r\n"
    assert h.hat.port == 2
    h = Hat(profile, echo=True)
    assert h.send(b"port;3\r") == b"port;3\r\nP3>"


# §2 "set sub-keywords": square, sine, triangle, pulse, ramp (+ var R6+)
SET_KEYWORDS = [(b"s", "square"), (b"sq", "square"), (b"si", "sine"), (b"t", "triangle"),
                (b"p", "pulse"), (b"r", "ramp"), (b"square", "square"), (b"sine", "sine"),
                (b"triangle", "triangle"), (b"pulse", "pulse"), (b"ramp", "ramp")]


@pytest.mark.parametrize("profile", ALL)
def test_set_sub_keywords(profile):
    for word, shape in SET_KEYWORDS:
        h = Hat(profile)
        assert h.send(b"set " + word + b" 0 1 1 0\r") == b"\r\n", word
        assert h.hat.controllers[0].generator.shape == shape, word
    for word in (b"v", b"var"):
        h = Hat(profile)
        out = h.send(b"set " + word + b" 0 1 1 0 0 0 0 u1 1 0\r")
        if profile in R6_R7:
            assert out == b"\r\n" and h.hat.controllers[0].generator.shape == "var"
        else:
            # "In R1–R5, `set v …` tries to read a number and gives `Error`."
            assert out == ERR and h.hat.controllers[0].generator.shape == "square"
    # "A sub-keyword must be followed by a space, `;` or end of line: `set sine0 …` → `Error`."
    h = Hat(profile)
    assert h.send(b"set sine0 0 1 1 0\r") == ERR
    h = Hat(profile)
    assert h.send(b"set sine;0 1 1 0\r") == b"\r\n" and h.hat.controllers[0].generator.shape == "sine"


# =====================================================================================
# §3 tokens, numbers, errors, clamping
# =====================================================================================
def _ctl(hat, port: int = 0):
    return hat.controllers[port]


# (section, line, expected bytes, state probe, expected probe value)
NUMBER_VECTORS = [
    # Separators
    ("§3 `port 1 vin⏎` runs both", b"port 1 vin\r", VIN, lambda h: h.port, 1),
    ("§3 `list 0⏎` lists, then Error", b"list 0\r",
     b"\r\n" + b"".join(b"P%d: no device detected\r\n" % p for p in range(4)) + b"Error\r\n", None, None),
    ("§3 a `;` ends the argument list", b"port 2;vin\r", VIN, lambda h: h.port, 2),
    # Unsigned
    ("§3 unsigned wraps modulo 2^32", b"port 4294967297\r", b"\r\n", lambda h: h.port, 1),
    ("§3 unsigned has no sign", b"port +1\r", ERR, lambda h: h.port, 0),
    ("§3 unsigned stops at the first non-digit", b"port 2vin\r", VIN, lambda h: h.port, 2),
    # Signed
    ("§3 signed `+N`", b"ledmode +2\r", b"\r\n", lambda h: h.ledmode, 2),
    ("§3 signed `+-1` fails", b"echo +-1\r", ERR, lambda h: h.echo, 0),
    ("§3 signed `- 1` fails", b"echo - 1\r", ERR, lambda h: h.echo, 0),
    ("§3 signed lone `-` fails", b"debug -\r", ERR, lambda h: h.debug, 0),
    ("§3 signed 32-bit result", b"debug 4294967295\r", b"\r\n", lambda h: h.debug, -1),
    # Float
    ("§3 float `.5`", b"set .5\r", b"\r\n", lambda h: _ctl(h).generator.a, 0.5),
    ("§3 float `5.`", b"set 5.\r", b"\r\n", lambda h: _ctl(h).generator.a, 5.0),
    ("§3 float `+3`", b"set +3\r", b"\r\n", lambda h: _ctl(h).generator.a, 3.0),
    ("§3 float `.` fails", b"set .\r", ERR, lambda h: _ctl(h).generator.a, 0.0),
    ("§3 float `-.` fails", b"set -.\r", ERR, lambda h: _ctl(h).generator.a, 0.0),
    ("§3 float `+` fails", b"set +\r", ERR, lambda h: _ctl(h).generator.a, 0.0),
    ("§3 no exponent: `1e3` is 1, then `e3` -> Error", b"set 1e3\r", ERR,
     lambda h: _ctl(h).generator.a, 1.0),
    ("§3 `0.0027777778` -> 0x3B360B61", b"set 0.0027777778\r", b"\r\n",
     lambda h: f32_bits(_ctl(h).generator.a), 0x3B360B61),
    ("§3 `-0` -> -0.0", b"set -0\r", b"\r\n", lambda h: f32_bits(_ctl(h).generator.a), 0x80000000),
    ("§3 9 significant digits kept", b"set 1.23456789999\r", b"\r\n",
     lambda h: f32_bits(_ctl(h).generator.a), f32_bits(123456789 / 1e8)),
    ("§3 format `u1x` = `u1` followed by the token `x`", b"select 1 0 u1x\r", ERR,
     lambda h: (h.ports[0].reporter.mode, h.ports[0].reporter.fmt), (1, 0x001)),
    # Trailing garbage
    ("§3 `port 1x⏎` -> port 1, then Error", b"port 1x\r", ERR, lambda h: h.port, 1),
    ("§3 `port 1.5⏎` -> port 1, then Error", b"port 1.5\r", ERR, lambda h: h.port, 1),
    ("§3 `set 0.5 0.3⏎` -> 0.5, then Error", b"set 0.5 0.3\r", ERR, lambda h: _ctl(h).generator.a, 0.5),
    # Errors: the rest of the line is thrown away, earlier effects stay
    ("§3 error drops the rest of the line", b"port 2 zz port 3\r", ERR, lambda h: h.port, 2),
    ("§3 failing command's rest dropped", b"echo x vin\r", ERR, lambda h: h.echo, 0),
    # Clamping table
    ("§3 clamp `port 9` -> 3", b"port 9\r", b"\r\n", lambda h: h.port, 3),
    ("§3 clamp `port -1` -> Error", b"port -1\r", ERR, lambda h: h.port, 0),
    ("§3 clamp ledmode high -> 3", b"ledmode 7\r", b"\r\n", lambda h: h.ledmode, 3),
    ("§3 clamp ledmode low -> -1", b"ledmode 0 ; ledmode -9\r", b"\r\n", lambda h: h.ledmode, -1),
    ("§3 echo stored as given", b"echo 123456\r", b"\r\nP0>", lambda h: h.echo, 123456),
    ("§3 debug stored as given", b"debug -2147483648\r", b"\r\n", lambda h: h.debug, -2147483648),
    ("§3 plimit 2 -> Q16 65536", b"plimit 2\r", b"\r\n",
     lambda h: [c.drive.limit for c in h.controllers], [65536] * 4),
    ("§3 plimit -1 -> Q16 0", b"plimit -1\r", b"\r\n",
     lambda h: [c.drive.limit for c in h.controllers], [0] * 4),
    ("§3 plimit 0.5 -> floor(x*65536+0.5)", b"plimit 0.5\r", b"\r\n",
     lambda h: _ctl(h, 3).drive.limit, 32768),
    ("§3 plimit 0.1 -> 6554", b"plimit 0.1\r", b"\r\n", lambda h: _ctl(h, 1).drive.limit, 6554),
    ("§3 `set <const>` not clamped", b"set 30\r", b"\r\n", lambda h: _ctl(h).generator.a, 30.0),
    ("§3 wave period clamped to >= 0.02, phase to [0,1]", b"set sine -1 1 0.001 7\r", b"\r\n",
     lambda h: (_ctl(h).generator.period, _ctl(h).generator.phase), (struct.unpack(
         "<f", struct.pack("<f", 0.02))[0], 1.0)),
    ("§3 `set <wave>` bad number: Error, nothing changes", b"set square -5 5 1e30 -3\r", ERR,
     lambda h: (_ctl(h).generator.shape, _ctl(h).generator.a, _ctl(h).generator.b), ("square", 0.0, 0.0)),
    ("§3 wave min/max unclamped", b"set square -5 5 2 -3\r", b"\r\n",
     lambda h: (_ctl(h).generator.a, _ctl(h).generator.b, _ctl(h).generator.period,
                _ctl(h).generator.phase), (-5.0, 5.0, 2.0, 0.0)),
]


@pytest.mark.parametrize("section,line,expected,probe,value", NUMBER_VECTORS,
                         ids=[v[0] for v in NUMBER_VECTORS])
def test_number_and_error_vectors(section, line, expected, probe, value):
    for profile in ALL:
        h = Hat(profile)
        assert h.send(line) == expected, profile
        if probe is not None:
            assert probe(h.hat) == value, profile


@pytest.mark.parametrize("profile", ALL)
def test_pid_numbers_per_profile_and_svar_clamps(profile):
    # §3 clamp table: "svar / pv: port, mode, offset | unsigned | 0..3, 0..15, 0..127" and
    # "scale, unwrap | float | not clamped"; "Kp, Ki, Kd, windup, deadzone | not clamped"
    line = b"pid 9 99 999 s2 -40 -50 -1 -2 -3 -4" + (b" -5" if profile in R6_R7 else b"") + b"\r"
    h = Hat(profile)
    assert h.send(line) == b"\r\n"
    pv, pid = _ctl(h.hat).pv, _ctl(h.hat).pid
    assert (pv.port, pv.mode, pv.offset, pv.scale, pv.unwrap) == (3, 15, 127, -40.0, -50.0)
    assert (pid.kp, pid.ki, pid.kd, pid.windup) == (-1.0, -2.0, -3.0, -4.0)
    if profile in R6_R7:
        assert pid.deadzone == -5.0
    assert _ctl(h.hat).pwmmode == 1


@pytest.mark.parametrize("profile", R1_R5)
def test_bias_clamp_r1_r5(profile):
    # §3: `bias` float, clamped to [0,1], then Q16 = floor(x·65536 + 0.5)
    for text, q16 in [(b"bias 2\r", 65536), (b"bias -1\r", 0), (b"bias .4\r", 26214)]:
        h = Hat(profile)
        assert h.send(text) == b"\r\n"
        assert _ctl(h.hat).drive.bias == q16


@pytest.mark.parametrize("profile", R6_R7)
def test_pwmparams_and_port_plimit_clamps_r6_plus(profile):
    # §3: pwmparams "each clamped to [0,1], then Q16 ...; both must be present or nothing changes";
    # port_plimit the current port only.
    h = Hat(profile)
    assert h.send(b"pwmparams 2 -1\r") == b"\r\n"
    assert (_ctl(h.hat).drive.pwmthresh, _ctl(h.hat).drive.minpwm) == (65536, 0)
    h = Hat(profile)
    assert h.send(b"pwmparams 0.5\r") == ERR
    assert (_ctl(h.hat).drive.pwmthresh, _ctl(h.hat).drive.minpwm) == (0, 0)
    h = Hat(profile)
    assert h.send(b"port 2 ; port_plimit 7\r") == b"\r\n"
    assert [c.drive.limit for c in h.hat.controllers] == [6554, 6554, 65536, 6554]


@pytest.mark.parametrize("profile", ALL)
def test_select_and_selrate_clamps(profile):
    # §3 clamp table: select/selonce mode 0..15, offset 0..127; selrate 0..1000000000 (R5+)
    h = Hat(profile)
    assert h.send(b"select 99 500 u1\r") == b"\r\n"
    rep = h.hat.ports[0].reporter
    assert (rep.mode, rep.offset) == (15, 127)
    h = Hat(profile)
    assert h.send(b"selonce -1\r") == b"\r\n"
    assert h.hat.ports[0].reporter.mode == 0
    if profile in R1_R5[:4]:
        assert Hat(profile).send(b"selrate 5\r") == ERR
        return
    for text, rate in [(b"selrate -5\r", 0), (b"selrate 2000000000\r", 1000000000), (b"selrate 7\r", 7)]:
        h = Hat(profile)
        assert h.send(b"select 1 ; " + text) == b"\r\n"
        assert h.hat.ports[0].reporter.rate == rate


@pytest.mark.parametrize("profile", ALL)
def test_combi_clamps_and_pair_cap(profile):
    # §3 clamp table: "index 0..7; mode 0..15; dataset 0..15; at most 15 pairs, after which the
    # remaining tokens are parsed as commands"
    h = Hat(profile)
    assert h.send(b"combi 9 16 17\r") == b"\r\n"
    assert h.hat.ports[0].combis[7] == [(15, 15)]
    pairs = b" ".join(b"1 0" for _ in range(15))
    h = Hat(profile)
    assert h.send(b"combi 0 " + pairs + b" 3\r") == ERR     # `3` is read as a command
    assert len(h.hat.ports[0].combis[0]) == 15
    h = Hat(profile)
    assert h.send(b"combi 0 " + pairs + b" vin\r") == VIN
    assert h.ran() == ["combi", "vin"]


# "Commands that can never fail ... still print `Error` if junk follows them."
NEVER_FAIL = ["help", "?", "clear_faults", "list", "coast", "pwm", "on", "off", "vin", "version",
              "signature"]


@pytest.mark.parametrize("name", NEVER_FAIL)
def test_commands_that_cannot_fail_error_on_junk(name, help_texts):
    for profile in ALL:
        h = Hat(profile)
        out = h.send(name.encode() + b"\r")
        expected = _output(name, profile, help_texts)
        assert out == expected if expected is not None else out.startswith(b"\r\nFirmware signature:")
        h2 = Hat(profile)
        assert h2.send(name.encode() + b" zz\r") == out + b"Error\r\n", profile


# =====================================================================================
# §4.3 help texts, exact bytes per profile
# =====================================================================================
@pytest.mark.parametrize("profile,size,nlines", [
    ("R1", 4136, 67), ("R2", 4136, 67), ("R3", 4136, 67), ("R4", 4136, 67), ("R5", 4293, 69),
    ("R6", 4201, 67), ("R7", 4201, 67)])
def test_help_text_exact(profile, size, nlines, help_texts):
    # §4.3: "R6–R7 (4201 bytes, 67 lines)", "R1–R4 (4136 bytes, 67 lines)", "R5 (4293 bytes, 69 lines)"
    text = help_texts[profile]
    assert len(text) == size and text.count(b"\r\n") == nlines     # the extraction is the facts'
    assert b"\xe2\x80\x93" in text and b"\xce\x94" in text            # `–` E2 80 93, `Δ` CE 94
    for command in (b"help\r", b"?\r"):
        assert Hat(profile).send(command) == b"\r\n" + text
    # with echo on: the echoed command, CRLF, the text, then the prompt
    assert Hat(profile, echo=True).send(b"?\r") == b"?\r\n" + text + b"P0>"


@pytest.mark.parametrize("profile", ALL)
def test_semicolon_ends_an_argument_list(profile):
    # §3 "each number parser skips only *spaces* after its token. A `;` therefore ends the
    # argument list": `set square 0;1 1 0` has only one number for the wave -> Error, no change.
    h = Hat(profile)
    assert h.send(b"set square 0;1 1 0\r") == ERR
    assert h.hat.controllers[0].generator.shape == "square" and h.hat.controllers[0].generator.b == 0.0
