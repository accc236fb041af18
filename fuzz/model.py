"""A reference model of the firmware's command port, written from FIRMWARE-FACTS §1-§4 and §6.

It is deliberately independent of ``emulator/`` (the fuzzer's oracle must not share the
emulator's bugs): its own line editor, matcher and number parsers. Fed the bytes the host sends,
it predicts what the HAT prints in answer (as :class:`Expect` items) and keeps the state a host
can observe: current port, echo, debug, the selection and combi table of every port, and the
controller settings (mode, coast, plimit) for targets that show the drive.

Behaviour the facts leave open is not guessed: the line is marked ``unspecified`` and the oracles
skip what depends on it (see :data:`UNSPECIFIED`).
"""
from __future__ import annotations

import re
import struct
from dataclasses import dataclass, field
from functools import cache, lru_cache
from typing import Dict, List, Optional, Tuple, Union

from ..protocol.profiles import Profile

__all__ = ["HatModel", "PortModel", "Expect", "LineFate", "UNSPECIFIED", "CR", "LINE_MAX", "expected_duty",
           "joined"]

CR, LF, BS, DEL, NUL = 0x0D, 0x0A, 0x08, 0x7F, 0x00
LINE_MAX = 256            # CMDBUFLEN (§1)
ACC_LIMIT = 100000000     # the float parser's digit accumulator stops growing here (§3)

# Situations FIRMWARE-FACTS does not settle; a line that hits one is not judged on them.
UNSPECIFIED = {
    "bs_when_full": "BS/DEL after the 256-byte buffer filled (§1 does not say whether it is discarded)",
}


def f32(x: float) -> float:
    """Round to IEEE single precision (the firmware computes in float)."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return float("inf") if x > 0 else float("-inf")


def q16(x: float) -> int:
    """plimit/bias/pwmparams storage: clamp to [0,1], then floor(x*65536 + 0.5) (§3)."""
    x = min(max(x, 0.0), 1.0)
    return int(f32(f32(x * 65536.0) + 0.5) // 1)


# -- expected output ------------------------------------------------------------------------

@dataclass(frozen=True)
class Expect:
    """One piece of predicted output.

    ``exact``: these bytes. ``pattern``: one CRLF-terminated line matching this regex.
    ``listing``: the ``list`` dump (4 port headers with active-device blocks). ``oracle`` says
    which oracle a mismatch here belongs to (prompt and echo bytes show state; outputs show fate).
    """

    kind: str                     # "exact" | "pattern" | "listing"
    data: bytes = b""
    pattern: str = ""
    oracle: str = "fate"
    what: str = ""

    def describe(self) -> str:
        if self.kind == "exact":
            return f"{self.what or 'bytes'} {self.data!r}"
        if self.kind == "pattern":
            return f"{self.what} line /{self.pattern}/"
        return "list dump of ports 0..3"


def _exact(data: bytes, what: str, oracle: str = "fate") -> Expect:
    return Expect("exact", data=data, oracle=oracle, what=what)


# Items predicted over and over, made once (Expect is frozen; H10 profile: building them was a
# visible share of a prediction).
_CRLF_ITEM = _exact(b"\r\n", "CRLF after CR")
_VIN_ITEM = Expect("pattern", pattern=r"\d+\.\d\d V", what="vin")
_SIGNATURE_ITEM = Expect("pattern", pattern=r"Firmware signature:( [0-9A-F]{2}){64}", what="signature")
_LISTING_ITEM = Expect("listing")


@lru_cache(maxsize=16)
def _prompt_item(port: int) -> Expect:
    return _exact(f"P{port}>".encode(), "prompt", "state")


@lru_cache(maxsize=1024)
def _error_item(failed: str) -> Expect:
    return _exact(b"Error\r\n", f"Error (from {failed!r})")


@dataclass
class LineFate:
    """What one CR-terminated line did according to the model."""

    raw: bytes                    # the stored line (after editing and the 256-byte limit)
    commands: List[str] = field(default_factory=list)   # resolved names that completed
    failed: Optional[str] = None  # the command (or unknown token) that printed Error
    unknown: Optional[str] = None  # set when the failure was a token that matched no command
    comment: bool = False
    unspecified: List[str] = field(default_factory=list)

    @property
    def error(self) -> bool:
        return self.failed is not None


def joined(first: List[Expect], second: List[Expect]) -> List[Expect]:
    """The prediction for two inputs fed at once, from the predictions for each in turn: an
    unfinished line's echo that runs on into the second is one item, as :meth:`HatModel.feed`
    of both would give (the echo only changes at a CR, which ends a run)."""
    if first and second and first[-1].what == "echo" and second[0].what == "echo":
        return first[:-1] + [_exact(first[-1].data + second[0].data, "echo", "state")] + second[1:]
    return first + second


# -- state ----------------------------------------------------------------------------------

@dataclass
class PortModel:
    mode: int = -1                # selected mode, -1 = none
    var: bool = False             # the `select <m> <off> <fmt>` form (prints P<p>V:)
    once: bool = False            # R1-R4 once flag (selonce)
    rate: int = -2                # R5+: -2 off, -1 once, 0 every message, N ms
    offset: int = 0
    combi: Dict[int, int] = field(default_factory=dict)   # index -> number of recorded pairs
    known: bool = True            # False after an event the model cannot follow exactly
    pwmmode: int = 0              # 0 direct PWM, 1 PID, 2 PID on the derivative
    coast: bool = False
    plimit: int = 6554            # R6+ per-port limit (Q16); reset with the port (§4.2)
    constant: Optional[float] = None  # the constant setpoint, when the generator holds one we know
    bias: int = 0                 # R1-R5 bias (Q16)
    pwmparams: Tuple[int, int] = (0, 0)   # R6+ (pwmthresh, minpwm), Q16
    device_modes: int = 0         # modes of the established active device here (0: none or unknown)
    tampered: bool = False        # write1/write2/combi reached the device: its mode is not ours to know

    def copy(self) -> PortModel:
        """An independent copy: every field is immutable except ``combi`` (a dict of ints).
        Much cheaper than ``dataclasses.replace``/``deepcopy``; the runner copies every port
        before and after every input."""
        fields = self.__dict__.copy()
        fields["combi"] = self.combi.copy()
        dup = object.__new__(type(self))
        dup.__dict__ = fields
        return dup

    def reporting(self, selrate_engine: bool) -> bool:
        if not 0 <= self.mode <= 7:     # modes 8..15 never report (§6.1)
            return False
        return self.rate != -2 if selrate_engine else True

    def report_form(self) -> str:
        """``V``, ``C<i>`` or ``M<m>``: the data line this selection prints."""
        if self.var:
            return "V"
        if self.combi.get(self.mode, 0) > 0:
            return f"C{self.mode}"
        return f"M{self.mode}"


class _Fail(Exception):
    """A command printed Error (the rest of the line is dropped)."""


# Each token and the spaces after it matched with one regex call, not a Python loop per byte
# (H10 profile: the model's per-byte loops were its main cost).
_COMMAND = re.compile(rb"[ ;]*([^ ;]*)(?:[ ;] *)?")   # separators, a token, one separator, spaces
_WORD = re.compile(rb"([^ ;]*)(?:[ ;] *)?")
_UNSIGNED = re.compile(rb"([0-9]*) *")
_HEX = re.compile(rb"([0-9a-fA-F]*) *")
_SIGNED = re.compile(rb"([+-]?)([0-9]*) *")
_FLOAT = re.compile(rb"([+-]?)([0-9]*)(?:\.([0-9]*))? *")
_FORMAT = re.compile(rb"(u1|s1|u2|s2|u4|s4|f4) *")   # exactly two characters; what follows is not checked
# All but _FORMAT also match the empty string: their ``match`` never fails (``assert m``).


@lru_cache(maxsize=64)
def _prefixes(names: Tuple[str, ...]) -> Dict[bytes, str]:
    """The matcher (§2) as a table: every non-empty prefix of a name -> the first name it starts."""
    table: Dict[bytes, str] = {}
    for name in names:
        encoded = name.encode()
        for end in range(1, len(encoded) + 1):
            table.setdefault(encoded[:end], name)
    return table


def _float_value(whole: bytes, fraction: bytes) -> float:
    """The float parser's accumulator (§3) over the digits before and after the point."""
    if len(whole) + len(fraction) <= 9:
        # Nine digits always fit (the accumulator stops only once it reaches 10^8).
        return f32(f32(float(int(whole + fraction))) / 10.0 ** len(fraction))
    acc = k = f = 0
    for c in whole:
        if acc < ACC_LIMIT:
            acc = acc * 10 + c - 0x30
        else:
            k += 1             # further integer digits scale by 10
    for c in fraction:
        if acc < ACC_LIMIT:
            acc = acc * 10 + c - 0x30
            f += 1             # further fraction digits are ignored
    return f32(f32(float(acc) * 10.0 ** k) / 10.0 ** f)


class _Cursor:
    __slots__ = ("s", "pos")

    def __init__(self, s: bytes, pos: int = 0):
        self.s = s
        self.pos = pos

    def command(self, prefixes: Dict[bytes, str]) -> Tuple[bytes, Optional[str]]:
        """Past the separators, (the token, the command it names or None); the token is empty
        at the end of the line. A command is consumed like :meth:`word` consumes a name."""
        m = _COMMAND.match(self.s, self.pos)
        assert m is not None
        tok = m.group(1)
        name = prefixes.get(tok) if tok else None
        if name is not None:
            self.pos = m.end()
        return tok, name

    # Number parsers (§3). Each returns None and leaves the position alone when no number
    # starts here, and skips the spaces (not ';') after a number it read.
    def unsigned(self) -> Optional[int]:
        m = _UNSIGNED.match(self.s, self.pos)
        assert m is not None
        digits = m.group(1)
        if not digits:
            return None
        self.pos = m.end()
        return int(digits) % 2**32

    def signed(self) -> Optional[int]:
        m = _SIGNED.match(self.s, self.pos)
        assert m is not None
        sign, digits = m.groups()
        if not digits:
            return None
        v = int(digits) % 2**32
        if sign == b"-":
            v = (-v) % 2**32
        self.pos = m.end()
        return v - 2**32 if v >= 2**31 else v

    def float(self) -> Optional[float]:
        m = _FLOAT.match(self.s, self.pos)
        assert m is not None
        sign, whole, fraction = m.groups()
        if not whole and not fraction:
            return None
        value = _float_value(whole, fraction or b"")
        self.pos = m.end()
        return -value if sign == b"-" else value

    def hex32(self) -> Optional[int]:
        m = _HEX.match(self.s, self.pos)
        assert m is not None
        digits = m.group(1)
        if not digits:
            return None
        self.pos = m.end()
        return int(digits, 16) % 2**32

    def format(self) -> Optional[bytes]:
        m = _FORMAT.match(self.s, self.pos)
        if m is None:
            return None
        self.pos = m.end()
        return m.group(1)

    def word(self, prefixes: Dict[bytes, str]) -> Optional[str]:
        """The matcher (§2): first name the token is a non-empty prefix of (``prefixes`` from
        :func:`_prefixes`)."""
        m = _WORD.match(self.s, self.pos)
        assert m is not None
        tok = m.group(1)
        name = prefixes.get(tok) if tok else None
        if name is not None:
            self.pos = m.end()
        return name

    # the same, raising _Fail
    def need(self, value):  # type: ignore[no-untyped-def]
        if value is None:
            raise _Fail()
        return value


def _clamp(v, lo, hi):  # type: ignore[no-untyped-def]
    return lo if v < lo else hi if v > hi else v


class HatModel:
    """The observable state of one HAT running ``profile``, and the parser that changes it."""

    def __init__(self, profile: Profile, devices: Optional[Dict[int, Optional[tuple]]] = None):
        self.profile = profile
        self.devices = dict(devices or {})
        self.port = 0
        self.echo = 0
        self.debug = 0
        self.ledmode = -1
        self.plimit = 6554                     # R1-R5 global limit (Q16)
        self.ports = [PortModel() for _ in range(4)]
        for port, spec in self.devices.items():
            if spec is not None and spec[0] == "active":
                self.ports[port].device_modes = _mode_count(spec[1])
        self.buffer = bytearray()
        self.overflowed_then_bs = False
        self.tainted: List[str] = []           # reasons the model lost track of the state
        self.selrate_engine = profile.feature("report_engine") == "selrate"
        self.per_port_plimit = profile.feature("plimit_scope") == "per_port"
        # What depends on the profile alone, looked up once rather than on every line.
        self._hash_comments = bool(profile.feature("hash_comments"))
        self._commands = _prefixes(tuple(profile.commands))
        self._set_keywords = _prefixes(tuple(profile.set_keywords))
        self._pid_extra = int(profile.feature("pid_numbers")) - 6
        self._combi_clears = bool(profile.feature("combi_clears_selection"))
        self._help_item = _exact(profile.help_bytes, "help text")
        version_line = f"Firmware version: {profile.version_string}\r\n".encode()
        self._version_item = _exact(version_line, "version line")
        self._signature_item = _SIGNATURE_ITEM      # unknown signature: its form only
        if profile.signature is not None:
            hexes = "".join(f" {b:02X}" for b in profile.signature)
            self._signature_item = _exact(f"Firmware signature:{hexes}\r\n".encode(), "signature line")

    def clone(self) -> HatModel:
        """An independent copy (the profile, which never changes, is shared)."""
        state = self.__dict__.copy()
        state["devices"] = dict(self.devices)
        state["ports"] = [p.copy() for p in self.ports]
        state["buffer"] = bytearray(self.buffer)
        state["tainted"] = list(self.tainted)
        dup = object.__new__(type(self))
        dup.__dict__ = state
        return dup

    def same_state(self, other: HatModel) -> bool:
        """True when ``other`` (typically a clone) is in exactly this state: fed the same
        bytes, the two predict the same."""
        return vars(self) == vars(other)

    def adopt(self, other: HatModel) -> None:
        """Take over the state of ``other``, a clone of this model fed since; ``other`` must
        not be used afterwards (its ports, buffer and lists become this model's)."""
        vars(self).update(vars(other))

    # -- the line editor (§1) --------------------------------------------------------------
    def feed(self, data: bytes) -> Tuple[List[Expect], List[LineFate]]:
        """Predict the answer to ``data`` and apply its effects."""
        out: List[Expect] = []
        fates: List[LineFate] = []
        pos, n = 0, len(data)
        # A run of bytes up to a CR at a time (H10 profile: a Python loop per byte was the
        # model's main cost); echo can only change when a line is processed, at the CR.
        while pos < n:
            end = data.find(b"\r", pos)
            stop = n if end < 0 else end
            if stop > pos:
                echo = self._edit(data[pos:stop])
                if echo and self.echo:
                    out.append(_exact(echo, "echo", "state"))
            if end < 0:
                break
            out.append(_CRLF_ITEM)
            fates.append(self._end_line(out))
            pos = end + 1
        return out, fates

    def _edit(self, run: bytes) -> bytes:
        """Store a run of bytes that holds no CR; returns what the editor echoes for it."""
        if b"\x08" not in run and b"\x7f" not in run:
            stored = run[:max(0, LINE_MAX - len(self.buffer))]   # the rest is dropped (§1)
            self.buffer += stored
            return stored
        echo = bytearray()
        for b in run:                        # rubouts: byte by byte
            if b in (BS, DEL):
                if len(self.buffer) >= LINE_MAX:
                    self.overflowed_then_bs = True
                if self.buffer:
                    self.buffer.pop()
                    echo += b"\x08 \x08"
            elif len(self.buffer) < LINE_MAX:
                self.buffer.append(b)
                echo.append(b)
        return bytes(echo)

    def _end_line(self, out: List[Expect]) -> LineFate:
        """The CR: the stored line is processed and the buffer starts afresh."""
        line = bytes(self.buffer)
        self.buffer.clear()
        fate = self._process(line, out)
        if self.overflowed_then_bs:
            fate.unspecified.append("bs_when_full")
            self.tainted.append(UNSPECIFIED["bs_when_full"])
            self.overflowed_then_bs = False
        return fate

    def _process(self, line: bytes, out: List[Expect]) -> LineFate:
        fate = LineFate(raw=line)
        if self._hash_comments and line[:1] == b"#":
            fate.comment = True                  # ignored: no Error and no prompt (R6+)
            return fate
        cur = _Cursor(line.split(b"\x00", 1)[0])   # NUL ends the line for the parser
        while True:
            token, name = cur.command(self._commands)
            if not token:
                break
            if name is None:
                fate.failed = fate.unknown = token.decode("latin-1")
                break
            try:
                getattr(self, _handler(name))(cur, out)
            except _Fail:
                fate.failed = name
                break
            fate.commands.append(name)
        if fate.failed is not None:
            out.append(_error_item(fate.failed))
        if self.echo:
            out.append(_prompt_item(self.port))
        return fate

    # -- commands (§4) ---------------------------------------------------------------------
    def _cmd_help(self, cur: _Cursor, out: List[Expect]) -> None:
        out.append(self._help_item)

    _cmd_q = _cmd_help

    def _cmd_version(self, cur: _Cursor, out: List[Expect]) -> None:
        out.append(self._version_item)

    def _cmd_signature(self, cur: _Cursor, out: List[Expect]) -> None:
        out.append(self._signature_item)

    def _cmd_vin(self, cur: _Cursor, out: List[Expect]) -> None:
        out.append(_VIN_ITEM)

    def _cmd_list(self, cur: _Cursor, out: List[Expect]) -> None:
        out.append(_LISTING_ITEM)

    def _cmd_clear_faults(self, cur: _Cursor, out: List[Expect]) -> None:
        pass

    def _cmd_port(self, cur: _Cursor, out: List[Expect]) -> None:
        self.port = _clamp(cur.need(cur.unsigned()), 0, 3)

    def _cmd_ledmode(self, cur: _Cursor, out: List[Expect]) -> None:
        self.ledmode = _clamp(cur.need(cur.signed()), -1, 3)

    def _cmd_echo(self, cur: _Cursor, out: List[Expect]) -> None:
        self.echo = cur.need(cur.signed())

    def _cmd_debug(self, cur: _Cursor, out: List[Expect]) -> None:
        self.debug = cur.need(cur.signed())

    def _here(self) -> PortModel:
        return self.ports[self.port]

    def _cmd_coast(self, cur: _Cursor, out: List[Expect]) -> None:
        self._here().coast = True

    def _cmd_pwm(self, cur: _Cursor, out: List[Expect]) -> None:
        p = self._here()
        p.pwmmode, p.coast = 0, False

    def _cmd_on(self, cur: _Cursor, out: List[Expect]) -> None:
        p = self._here()
        p.coast, p.constant = False, 1.0          # only the setpoint; the mode stays (§4.1)

    def _cmd_off(self, cur: _Cursor, out: List[Expect]) -> None:
        p = self._here()
        p.coast, p.constant = False, 0.0

    def _svar(self, cur: _Cursor) -> None:
        for parse in (cur.unsigned, cur.unsigned, cur.unsigned, cur.format, cur.float, cur.float):
            cur.need(parse())

    def _pid(self, cur: _Cursor, mode: int) -> None:
        p = self._here()
        try:
            self._svar(cur)
            for _ in range(self._pid_extra):
                cur.need(cur.float())
        except _Fail:
            p.pwmmode, p.coast = 0, False        # the error path forces direct PWM (§3)
            raise
        p.pwmmode, p.coast = mode, False

    def _cmd_pid(self, cur: _Cursor, out: List[Expect]) -> None:
        self._pid(cur, 1)

    def _cmd_pid_diff(self, cur: _Cursor, out: List[Expect]) -> None:
        self._pid(cur, 2)

    def _cmd_set(self, cur: _Cursor, out: List[Expect]) -> None:
        kw = cur.word(self._set_keywords)
        p = self._here()
        if kw is None:
            p.constant = cur.need(cur.float())
        elif kw == "var":
            for _ in range(4):
                cur.need(cur.float())
            p.constant = None
            self._svar(cur)
        else:
            for _ in range(4):                   # all four parsed before anything is stored
                cur.need(cur.float())
            p.constant = None
        p.coast = False

    def _cmd_bias(self, cur: _Cursor, out: List[Expect]) -> None:
        self._here().bias = q16(cur.need(cur.float()))

    def _cmd_plimit(self, cur: _Cursor, out: List[Expect]) -> None:
        v = q16(cur.need(cur.float()))
        if self.per_port_plimit:
            for p in self.ports:
                p.plimit = v
        else:
            self.plimit = v

    def _cmd_port_plimit(self, cur: _Cursor, out: List[Expect]) -> None:
        self._here().plimit = q16(cur.need(cur.float()))

    def _cmd_pwmparams(self, cur: _Cursor, out: List[Expect]) -> None:
        thresh = q16(cur.need(cur.float()))
        self._here().pwmparams = (thresh, q16(cur.need(cur.float())))

    def _select(self, cur: _Cursor, once: bool) -> None:
        p = self._here()
        mode = cur.signed()
        if mode is None:                         # no argument: stop reporting
            p.mode, p.var, p.once = -1, False, False
            p.rate = -2
            if once:
                p.known = False                  # `selonce` alone: §6 names only `select`
            return
        p.mode, p.var, p.once = _clamp(mode, 0, 15), False, once
        offset = cur.signed()
        if offset is not None:
            p.offset = _clamp(offset, 0, 127)
            if cur.format() is None:             # offset without format: reporting off (§3)
                p.mode = -1
                raise _Fail()
            p.var = True
        p.rate = -1 if once else 100
        p.known = True

    def _cmd_select(self, cur: _Cursor, out: List[Expect]) -> None:
        self._select(cur, once=False)

    def _cmd_selonce(self, cur: _Cursor, out: List[Expect]) -> None:
        self._select(cur, once=True)

    def _cmd_selrate(self, cur: _Cursor, out: List[Expect]) -> None:
        self._here().rate = _clamp(cur.need(cur.signed()), 0, 1000000000)

    def _cmd_combi(self, cur: _Cursor, out: List[Expect]) -> None:
        p = self._here()
        index = _clamp(cur.need(cur.signed()), 0, 7)
        p.tampered = True
        if self._combi_clears:
            # §6.2 says combi sets the mode to -1; whether an odd list does so too is not said.
            p.mode = -1
            p.known = False
        pairs = 0
        p.combi[index] = 0
        while pairs < 15:
            if cur.signed() is None:
                break
            if cur.signed() is None:             # odd count: the pairs so far are recorded
                p.combi[index] = pairs
                raise _Fail()
            pairs += 1
            p.combi[index] = pairs
        if self._combi_clears:
            p.known = True

    def _write(self, cur: _Cursor, headers: int) -> None:
        self._here().tampered = True
        for _ in range(headers):
            cur.need(cur.hex32())
        n = 0
        while n < 128 and cur.hex32() is not None:
            n += 1

    def _cmd_write1(self, cur: _Cursor, out: List[Expect]) -> None:
        self._write(cur, 1)

    def _cmd_write2(self, cur: _Cursor, out: List[Expect]) -> None:
        self._write(cur, 2)

    # -- what the world does (seen in asynchronous lines) ------------------------------------
    def saw_report(self, port: int) -> None:
        """A data line for ``port`` arrived: once-selections end (§6.2)."""
        self.report_seen(self.ports[port])

    def report_seen(self, p: PortModel) -> None:
        """The once-selection of ``p`` (a port's state) has reported: it ends (§6.2)."""
        if self.selrate_engine:
            if p.rate == -1:
                p.rate = -2
        elif p.once and not p.var:
            p.mode = -1

    def saw_link_change(self, port: int) -> None:
        """A device on ``port`` connected or went away: its selection and combi records reset."""
        p = self.ports[port]
        p.combi.clear()
        p.device_modes = 0
        p.constant = None                        # the port reset (§4.2) and what follows it
        p.known = False


def expected_duty(profile: Profile, p: PortModel, global_plimit: int) -> Optional[Union[int, str]]:
    """The motor-driver duty (±255, or "coast") a port in direct-PWM mode settles at (§7.3), or
    None when the model does not know it (PID, a waveform, bias or pwmparams in play)."""
    if p.coast:
        return "coast"
    if p.pwmmode != 0 or p.constant is None or p.bias or p.pwmparams != (0, 0):
        return None
    x = min(max(p.constant, -1.0), 1.0)
    t = int(f32(x * 131072.0))                 # trunc toward zero
    u = int((t + 1) / 2)                       # C integer division: toward zero
    limit = p.plimit if profile.feature("plimit_scope") == "per_port" else global_plimit
    v = min(max(u, -limit), limit)
    return (v * 255 + 127) >> 16               # arithmetic shift: floor


def _mode_count(type_id: int) -> int:
    """How many modes an active device has (the device catalogue); 0 if it is not catalogued."""
    from ..protocol.devices import active_device
    try:
        return int(active_device(type_id).get("mode_count", 0))
    except KeyError:
        return 0


def established(p: PortModel, type_id: int) -> None:
    """An active device finished its setup on this port: a clean slate (§5)."""
    p.device_modes = _mode_count(type_id)
    p.tampered = False
    p.combi.clear()


@cache
def _handler(name: str) -> str:
    """The method that runs command ``name`` (``?`` -> ``_cmd_q``, ``pid_diff`` -> ``_cmd_pid_diff``)."""
    return "_cmd_" + ("q" if name == "?" else re.sub(r"\W", "_", name))
