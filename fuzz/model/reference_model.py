"""A reference model of the firmware's command port, written from docs/FIRMWARE-BEHAVIOUR.md
(#fb-line, #fb-matching, #fb-arguments, #fb-commands, #fb-data).

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
from functools import cache
from typing import Dict, List, Optional, Tuple

from ...protocol.profiles import Profile
from ..oracles.built_in import STATE
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
from .line_parsing import Cursor, LineFailed, clamp, prefix_table, q16
from .port_model import PortModel, mode_count

__all__ = ["ReferenceModel", "UNSPECIFIED", "CR", "LINE_MAX"]

CR, LF, BS, DEL, NUL = 0x0D, 0x0A, 0x08, 0x7F, 0x00
_RUBOUTS = re.compile(rb"([\x08\x7f])")
LINE_MAX = 256            # the line buffer (FIRMWARE-BEHAVIOUR.md#fb-line-buffer)

# Situations the facts (docs/FIRMWARE-BEHAVIOUR.md) do not settle; a line that hits one is not judged on them.
UNSPECIFIED = {
    "bs_when_full": "BS/DEL after the 256-byte buffer filled (docs/FIRMWARE-BEHAVIOUR.md#fb-line-buffer "
                    "does not say whether it is discarded)",
}



def _q16_arg(cur: Cursor) -> int:
    """The next argument, a float the firmware stores as Q16.16 (bias, plimit, pwmparams)."""
    return q16(cur.need(cur.float()))

class ReferenceModel:
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
                self.ports[port].device_modes = mode_count(spec[1])
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

    def clone(self) -> ReferenceModel:
        """An independent copy (the profile, which never changes, is shared)."""
        state = self.__dict__.copy()
        state["devices"] = dict(self.devices)
        state["ports"] = [p.copy() for p in self.ports]
        state["buffer"] = bytearray(self.buffer)
        state["tainted"] = list(self.tainted)
        dup = object.__new__(type(self))
        dup.__dict__ = state
        return dup

    def same_state(self, other: ReferenceModel) -> bool:
        """True when ``other`` (typically a clone) is in exactly this state: fed the same
        bytes, the two predict the same."""
        return vars(self) == vars(other)

    def adopt(self, other: ReferenceModel) -> None:
        """Take over the state of ``other``, a clone of this model fed since; ``other`` must
        not be used afterwards (its ports, buffer and lists become this model's)."""
        vars(self).update(vars(other))

    # -- the line editor (fb-line) --------------------------------------------------------------
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
                    out.append(exact_item(echo, "echo", STATE.name))
            if end < 0:
                break
            out.append(CRLF_ITEM)
            fates.append(self._end_line(out))
            pos = end + 1
        return out, fates

    def _edit(self, run: bytes) -> bytes:
        """Store a run of bytes that holds no CR; returns what the editor echoes for it."""
        if b"\x08" not in run and b"\x7f" not in run:
            stored = run[:max(0, LINE_MAX - len(self.buffer))]   # the rest is dropped (fb-line-buffer)
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

    # -- commands (fb-commands) ----------------------------------------------------------------
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
        for p in self.ports:
            p.forward_flag = True

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
        p.coast, p.constant = False, 1.0          # only the setpoint; the mode stays (fb-on-off)

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
            p.pwmmode, p.coast = 0, False        # the error path forces direct PWM (fb-pid-error)
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
            try:
                self._svar(cur)
            except LineFailed:
                # The shape and its four numbers are stored (fb-errors); whether coast ends too the facts
                # do not say (the firmware in the loop ends it). Not coasting, with no constant set-point
                # known, leaves the drive unjudged until a command the facts settle.
                p.coast = False
                raise
        else:
            for _ in range(4):                   # all four parsed before anything is stored
                cur.need(cur.float())
            p.constant = None
        p.coast = False

    def _cmd_bias(self, cur: Cursor, out: List[Expect]) -> None:
        self._here().bias = _q16_arg(cur)

    def _cmd_plimit(self, cur: Cursor, out: List[Expect]) -> None:
        v = _q16_arg(cur)
        if self.per_port_plimit:
            for p in self.ports:
                p.plimit = v
        else:
            self.plimit = v

    def _cmd_port_plimit(self, cur: Cursor, out: List[Expect]) -> None:
        self._here().plimit = _q16_arg(cur)

    def _cmd_pwmparams(self, cur: Cursor, out: List[Expect]) -> None:
        thresh = _q16_arg(cur)
        self._here().pwmparams = (thresh, _q16_arg(cur))

    def _select(self, cur: Cursor, once: bool) -> None:
        p = self._here()
        self.selections += 1
        p.selection = self.selections
        mode = cur.signed()
        if mode is None:                         # no argument: stop reporting
            p.mode, p.var, p.once = -1, False, False
            p.rate = -2
            if once:
                p.known = False                  # `selonce` alone: fb-reporting names only `select`
            return
        p.mode, p.var, p.once = clamp(mode, 0, 15), False, once
        offset = cur.signed()
        if offset is not None:
            p.offset = clamp(offset, 0, 127)
            if cur.format() is None:             # offset without format: reporting off (fb-select-error)
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
        selected = p.mode
        if self._combi_clears:
            # fb-select-resend says combi deselects; whether an odd list does so too is not said.
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
                # Still unknown, but the mode stays a selection that may report: the firmware in
                # the loop kept streaming after it (sil/README.md), and a port taken for silent
                # held no room for its reports in the TX ring (fuzz/model/tx_ring.py's backlog).
                p.mode = selected
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
        """A data line for ``port`` arrived: once-selections end (fb-reporting)."""
        self.report_seen(self.ports[port])

    def report_seen(self, p: PortModel) -> None:
        """The once-selection of ``p`` (a port's state) has reported: it ends (fb-reporting)."""
        if self.selrate_engine:
            if p.rate == -1:
                p.rate = -2
        elif p.once and not p.var:
            p.mode = -1


@cache
def _handler(name: str) -> str:
    """The method that runs command ``name`` (``?`` -> ``_cmd_q``, ``pid_diff`` -> ``_cmd_pid_diff``)."""
    return "_cmd_" + ("q" if name == "?" else re.sub(r"\W", "_", name))
