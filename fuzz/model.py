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
from dataclasses import dataclass, field
from functools import cache
from typing import Dict, FrozenSet, List, Optional, Tuple, Union

from ..protocol.profiles import Profile
from .expect import (
    CRLF_ITEM,
    LISTING_ITEM,
    SIGNATURE_ITEM,
    VIN_ITEM,
    Expect,
    LineFate,
    error_item,
    exact_item,
    prompt_item,
)
from .lineparse import Cursor, LineFailed, clamp, f32, prefix_table, q16

__all__ = ["HatModel", "PortModel", "UNSPECIFIED", "CR", "LINE_MAX", "expected_duty", "established"]

CR, LF, BS, DEL, NUL = 0x0D, 0x0A, 0x08, 0x7F, 0x00
_RUBOUTS = re.compile(rb"([\x08\x7f])")
LINE_MAX = 256            # CMDBUFLEN (§1)

# Situations FIRMWARE-FACTS does not settle; a line that hits one is not judged on them.
UNSPECIFIED = {
    "bs_when_full": "BS/DEL after the 256-byte buffer filled (§1 does not say whether it is discarded)",
}


# -- state ----------------------------------------------------------------------------------

@dataclass
class PortModel:
    mode: int = -1                # selected mode, -1 = none
    var: bool = False             # the `select <m> <off> <fmt>` form (prints P<p>V:)
    once: bool = False            # R1-R4 once flag (selonce)
    rate: int = -2                # R5+: -2 off, -1 once, 0 every message, N ms
    selection: int = 0            # which select/selonce made it (a report ends only its own once)
    offset: int = 0
    combi: Dict[int, int] = field(default_factory=dict)   # index -> number of recorded pairs
    # Indices whose entry the model has not seen set: a HAT kept open from an earlier run keeps
    # its combi table through the prelude (only a new connection clears it, §6.1, §6.2).
    combi_unknown: FrozenSet[int] = frozenset()
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

    def report_forms(self) -> Tuple[str, ...]:
        """The data line this selection prints: ``V``, ``C<i>`` or ``M<m>`` (§6.1); both ``C<m>``
        and ``M<m>`` when the combi entry of the mode is not known."""
        if self.var:
            return ("V",)
        if self.combi.get(self.mode, 0) > 0:
            return (f"C{self.mode}",)
        if self.mode in self.combi_unknown:
            return (f"C{self.mode}", f"M{self.mode}")
        return (f"M{self.mode}",)

    def forget_combis(self) -> None:
        """The combi table may hold anything (a run on a HAT an earlier run left)."""
        self.combi.clear()
        self.combi_unknown = frozenset(range(8))

    def clear_combis(self) -> None:
        """The combi table is empty (a new connection)."""
        self.combi.clear()
        self.combi_unknown = frozenset()

    def link_changed(self, type_id: Optional[int] = None) -> None:
        """A device connected, went away or failed (§5): the select state resets (the model no
        longer knows it) and the port reset (§4.2) drops the setpoint. ``type_id``: a device
        with this type id finished its setup (``established``)."""
        self.known = False
        self.constant = None
        if type_id is None:
            self.device_modes = 0
            self.clear_combis()     # a new connection clears the table (§8); none reports before it
        else:
            established(self, type_id)


class HatModel:
    """The observable state of one HAT running ``profile``, and the parser that changes it."""

    def __init__(self, profile: Profile, devices: Optional[Dict[int, Optional[tuple]]] = None):
        self.profile = profile
        self.devices = dict(devices or {})
        self.port = 0
        self.echo = 0
        self.debug = 0
        self.debug_seen = 0                    # every debug bit set since the caller cleared it
        self.ledmode = -1
        self.plimit = 6554                     # R1-R5 global limit (Q16)
        self.ports = [PortModel() for _ in range(4)]
        self.selections = 0                    # select/selonce commands run (PortModel.selection)
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
        self._commands = prefix_table(tuple(profile.commands))
        self._set_keywords = prefix_table(tuple(profile.set_keywords))
        self._pid_extra = int(profile.feature("pid_numbers")) - 6
        self._combi_clears = bool(profile.feature("combi_clears_selection"))
        self._help_item = exact_item(profile.help_bytes, "help text")
        version_line = f"Firmware version: {profile.version_string}\r\n".encode()
        self._version_item = exact_item(version_line, "version line")
        self._signature_item = SIGNATURE_ITEM      # unknown signature: its form only
        if profile.signature is not None:
            hexes = "".join(f" {b:02X}" for b in profile.signature)
            self._signature_item = exact_item(f"Firmware signature:{hexes}\r\n".encode(), "signature line")

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
                    out.append(exact_item(echo, "echo", "state"))
            if end < 0:
                break
            out.append(CRLF_ITEM)
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
        buffer = self.buffer
        for piece in _RUBOUTS.split(run):    # the bytes between rubouts, and each rubout
            if piece == b"\x08" or piece == b"\x7f":
                if len(buffer) >= LINE_MAX:
                    self.overflowed_then_bs = True
                if buffer:
                    buffer.pop()
                    echo += b"\x08 \x08"
            elif piece:
                stored = piece[:max(0, LINE_MAX - len(buffer))]
                buffer += stored
                echo += stored
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
        cur = Cursor(line.split(b"\x00", 1)[0])   # NUL ends the line for the parser
        while True:
            token, name = cur.command(self._commands)
            if not token:
                break
            if name is None:
                fate.failed = fate.unknown = token.decode("latin-1")
                break
            try:
                getattr(self, _handler(name))(cur, out)
            except LineFailed:
                fate.failed = name
                break
            fate.commands.append(name)
        if fate.failed is not None:
            out.append(error_item(fate.failed))
        if self.echo:
            out.append(prompt_item(self.port))
        return fate

    # -- commands (§4) ---------------------------------------------------------------------
    def _cmd_help(self, cur: Cursor, out: List[Expect]) -> None:
        out.append(self._help_item)

    _cmd_q = _cmd_help

    def _cmd_version(self, cur: Cursor, out: List[Expect]) -> None:
        out.append(self._version_item)

    def _cmd_signature(self, cur: Cursor, out: List[Expect]) -> None:
        out.append(self._signature_item)

    def _cmd_vin(self, cur: Cursor, out: List[Expect]) -> None:
        out.append(VIN_ITEM)

    def _cmd_list(self, cur: Cursor, out: List[Expect]) -> None:
        out.append(LISTING_ITEM)

    def _cmd_clear_faults(self, cur: Cursor, out: List[Expect]) -> None:
        pass

    def _cmd_port(self, cur: Cursor, out: List[Expect]) -> None:
        self.port = clamp(cur.need(cur.unsigned()), 0, 3)

    def _cmd_ledmode(self, cur: Cursor, out: List[Expect]) -> None:
        self.ledmode = clamp(cur.need(cur.signed()), -1, 3)

    def _cmd_echo(self, cur: Cursor, out: List[Expect]) -> None:
        self.echo = cur.need(cur.signed())

    def _cmd_debug(self, cur: Cursor, out: List[Expect]) -> None:
        self.debug = cur.need(cur.signed())
        self.debug_seen |= self.debug

    def _here(self) -> PortModel:
        return self.ports[self.port]

    def _cmd_coast(self, cur: Cursor, out: List[Expect]) -> None:
        self._here().coast = True

    def _cmd_pwm(self, cur: Cursor, out: List[Expect]) -> None:
        p = self._here()
        p.pwmmode, p.coast = 0, False

    def _cmd_on(self, cur: Cursor, out: List[Expect]) -> None:
        p = self._here()
        p.coast, p.constant = False, 1.0          # only the setpoint; the mode stays (§4.1)

    def _cmd_off(self, cur: Cursor, out: List[Expect]) -> None:
        p = self._here()
        p.coast, p.constant = False, 0.0

    def _svar(self, cur: Cursor) -> None:
        for parse in (cur.unsigned, cur.unsigned, cur.unsigned, cur.format, cur.float, cur.float):
            cur.need(parse())

    def _pid(self, cur: Cursor, mode: int) -> None:
        p = self._here()
        try:
            self._svar(cur)
            for _ in range(self._pid_extra):
                cur.need(cur.float())
        except LineFailed:
            p.pwmmode, p.coast = 0, False        # the error path forces direct PWM (§3)
            raise
        p.pwmmode, p.coast = mode, False

    def _cmd_pid(self, cur: Cursor, out: List[Expect]) -> None:
        self._pid(cur, 1)

    def _cmd_pid_diff(self, cur: Cursor, out: List[Expect]) -> None:
        self._pid(cur, 2)

    def _cmd_set(self, cur: Cursor, out: List[Expect]) -> None:
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

    def _cmd_bias(self, cur: Cursor, out: List[Expect]) -> None:
        self._here().bias = q16(cur.need(cur.float()))

    def _cmd_plimit(self, cur: Cursor, out: List[Expect]) -> None:
        v = q16(cur.need(cur.float()))
        if self.per_port_plimit:
            for p in self.ports:
                p.plimit = v
        else:
            self.plimit = v

    def _cmd_port_plimit(self, cur: Cursor, out: List[Expect]) -> None:
        self._here().plimit = q16(cur.need(cur.float()))

    def _cmd_pwmparams(self, cur: Cursor, out: List[Expect]) -> None:
        thresh = q16(cur.need(cur.float()))
        self._here().pwmparams = (thresh, q16(cur.need(cur.float())))

    def _select(self, cur: Cursor, once: bool) -> None:
        p = self._here()
        self.selections += 1
        p.selection = self.selections
        mode = cur.signed()
        if mode is None:                         # no argument: stop reporting
            p.mode, p.var, p.once = -1, False, False
            p.rate = -2
            if once:
                p.known = False                  # `selonce` alone: §6 names only `select`
            return
        p.mode, p.var, p.once = clamp(mode, 0, 15), False, once
        offset = cur.signed()
        if offset is not None:
            p.offset = clamp(offset, 0, 127)
            if cur.format() is None:             # offset without format: reporting off (§3)
                p.mode = -1
                raise LineFailed()
            p.var = True
        p.rate = -1 if once else 100
        p.known = True

    def _cmd_select(self, cur: Cursor, out: List[Expect]) -> None:
        self._select(cur, once=False)

    def _cmd_selonce(self, cur: Cursor, out: List[Expect]) -> None:
        self._select(cur, once=True)

    def _cmd_selrate(self, cur: Cursor, out: List[Expect]) -> None:
        self._here().rate = clamp(cur.need(cur.signed()), 0, 1000000000)

    def _cmd_combi(self, cur: Cursor, out: List[Expect]) -> None:
        p = self._here()
        index = clamp(cur.need(cur.signed()), 0, 7)
        p.tampered = True
        if self._combi_clears:
            # §6.2 says combi sets the mode to -1; whether an odd list does so too is not said.
            p.mode = -1
            p.known = False
        pairs = 0
        p.combi[index] = 0
        p.combi_unknown = p.combi_unknown - {index}
        while pairs < 15:
            if cur.signed() is None:
                break
            if cur.signed() is None:             # odd count: the pairs so far are recorded
                p.combi[index] = pairs
                raise LineFailed()
            pairs += 1
            p.combi[index] = pairs
        if self._combi_clears:
            p.known = True

    def _write(self, cur: Cursor, headers: int) -> None:
        self._here().tampered = True
        for _ in range(headers):
            cur.need(cur.hex32())
        n = 0
        while n < 128 and cur.hex32() is not None:
            n += 1

    def _cmd_write1(self, cur: Cursor, out: List[Expect]) -> None:
        self._write(cur, 1)

    def _cmd_write2(self, cur: Cursor, out: List[Expect]) -> None:
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
    """An active device finished its setup on this port (§5). The connection cleared the combi
    table when it began; the facts do not say whether an entry set during the setup survives
    (§8 keeps it in the slot of mode i's info, which the setup fills), so those entries, and any
    the model did not see the connection begin after, are unknown."""
    p.device_modes = _mode_count(type_id)
    p.tampered = False
    p.combi_unknown = p.combi_unknown | frozenset(p.combi)
    p.combi.clear()


@cache
def _handler(name: str) -> str:
    """The method that runs command ``name`` (``?`` -> ``_cmd_q``, ``pid_diff`` -> ``_cmd_pid_diff``)."""
    return "_cmd_" + ("q" if name == "?" else re.sub(r"\W", "_", name))
