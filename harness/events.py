"""The line classifier: every line the command port prints becomes one typed :class:`Event`.

The patterns are data (the ``LINE_PATTERNS`` table of (kind, regex, field parser)), taken
from FIRMWARE-BEHAVIOUR.md (#fb-commands to #fb-bootloader). The first matching row wins, so
more specific rows come first.
Prompts (``P0>``, ``BHBL> ``) arrive without CRLF; :class:`~.line_splitter.LineSplitter`
turns a byte stream into complete lines and prompts, and recognises the echo of the host's lines.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Callable, Dict, FrozenSet, List, Optional, Pattern, Sequence, Tuple, Union

__all__ = ["Event", "classify", "line_kind", "decode", "LINE_PATTERNS", "KINDS", "PORT_STATUS_KINDS",
           "UNASKED_KINDS", "parse_value"]


@dataclass
class Event:
    """One line (or prompt) from the HAT.

    ``kind`` names what it is (see ``KINDS``); ``text`` is the line decoded leniently (no
    CRLF); ``raw`` its exact bytes; ``t`` milliseconds since the session opened;
    ``fields`` the parsed values (port, mode, values, volts, ...).
    """

    kind: str
    text: str
    raw: bytes = b""
    t: float = 0.0
    fields: Dict[str, object] = field(default_factory=dict)

    @property
    def port(self) -> Optional[int]:
        p = self.fields.get("port")
        return p if isinstance(p, int) else None

    @property
    def is_port_status(self) -> bool:
        """True for the per-port line of ``list`` (also printed when a device connects)."""
        return self.kind in PORT_STATUS_KINDS

    def __str__(self) -> str:
        return f"{self.t:9.1f} ms  {self.kind:<18} {self.text!r}"


# -- value parsers ---------------------------------------------------------------------
_INT_RE = re.compile(r"^[+-]?\d+$")


def parse_value(token: str) -> Union[int, float]:
    """One value of a data line: ``+5`` / ``-5`` / ``0`` are ints; the float printer's
    output (``1.50000``, ``-1.00000E-3``, ``Inf``, ``-NaN``) is a float."""
    if _INT_RE.match(token):
        return int(token)
    t = token.lstrip("-")
    sign = -1.0 if token.startswith("-") else 1.0
    if t == "Inf":
        return sign * float("inf")
    if t == "NaN":
        return float("nan")
    return float(token)


def _values(s: str) -> List[Union[int, float]]:
    return [parse_value(tok) for tok in s.split()]


def _hexport(s: str) -> int:
    return int(s, 16)


# A field parser turns a match into the event's fields.
FieldParser = Callable[["re.Match[str]"], Dict[str, object]]


def _port(m: re.Match[str]) -> Dict[str, object]:
    return {"port": _hexport(m.group("p"))}


def _none(_m: re.Match[str]) -> Dict[str, object]:
    return {}


def _with(**extra: object) -> FieldParser:
    def parse(m: re.Match[str]) -> Dict[str, object]:
        out: Dict[str, object] = {k: v for k, v in m.groupdict().items() if k != "p"}
        if "p" in m.groupdict():
            out["port"] = _hexport(m.group("p"))
        out.update(extra)
        return out
    return parse


def _version(m: re.Match[str]) -> Dict[str, object]:
    s = m.group("v")
    num = s.split()[0] if s.split() else ""
    return {"version": s, "number": int(num) if num.isdigit() else None}


def _vin(m: re.Match[str]) -> Dict[str, object]:
    return {"volts": float(m.group("v")), "centivolts": int(m.group("v").replace(".", ""))}


def _mode_data(m: re.Match[str]) -> Dict[str, object]:
    return {"port": _hexport(m.group("p")), "mode": int(m.group("m")), "values": _values(m.group("vals")),
            "tokens": m.group("vals").split()}


def _combi_data(m: re.Match[str]) -> Dict[str, object]:
    return {"port": _hexport(m.group("p")), "index": int(m.group("i")), "values": _values(m.group("vals")),
            "tokens": m.group("vals").split()}


def _var_data(m: re.Match[str]) -> Dict[str, object]:
    return {"port": _hexport(m.group("p")), "value": parse_value(m.group("v")), "token": m.group("v")}


def _pid_debug(m: re.Match[str]) -> Dict[str, object]:
    out: Dict[str, object] = {"port": _hexport(m.group("p"))}
    for k in ("pv", "sp", "e", "ie", "de", "cv"):
        out[k] = parse_value(m.group(k))
    return out


def _data_debug(m: re.Match[str]) -> Dict[str, object]:
    payload = (m.group("payload") or "").split()
    return {"port": _hexport(m.group("p")), "mode": int(m.group("m"), 16),
            "payload": bytes(int(b, 16) for b in payload)}


def _hex_bytes(m: re.Match[str]) -> Dict[str, object]:
    return {"bytes": bytes(int(b, 16) for b in m.group("hex").split())}


def _fault_row(m: re.Match[str]) -> Dict[str, object]:
    return {"port": int(m.group("p")), "flags": bytes(int(b, 16) for b in m.group("flags").split())}


def _list_port(state: str) -> FieldParser:
    def parse(m: re.Match[str]) -> Dict[str, object]:
        out: Dict[str, object] = {"port": _hexport(m.group("p")), "state": state}
        if state == "active":
            out["id"] = int(m.group("id"), 16)
        elif state == "passive":
            out["id"] = int(m.group("id"))
        return out
    return parse


_DECIMAL_LIST_FIELDS = {"value_dec", "mode", "count", "type_code", "chars", "dp", "index"}


def _list_line(name: str) -> FieldParser:
    def parse(m: re.Match[str]) -> Dict[str, object]:
        out: Dict[str, object] = {"field": name}
        for k, v in m.groupdict().items():
            # decimal fields become ints; hex ones (hwver, swver, type) stay as printed
            if k in _DECIMAL_LIST_FIELDS:
                out["value" if k == "value_dec" else k] = int(v)
            else:
                out[k] = v
        return out
    return parse


def _range_line(m: re.Match[str]) -> Dict[str, object]:
    return {"field": "range", **{k: (int(m.group(k + "0"), 16), int(m.group(k + "1"), 16))
                                 for k in ("raw", "pct", "si")}}


_P = r"P(?P<p>[0-9a-f])"          # the port is one hex digit in every asynchronous line
_F = r"-?(?:\d+(?:\.\d*)?(?:E-?\d+)?|Inf|NaN)"  # the firmware float printer's output
_H8 = r"[0-9A-F]{8}"
_V = rf"(?:[+-]?\d+|{_F})"        # one value of a data line: a signed integer or a float

# (kind, regex (full match against the decoded line), field parser); first match wins.
LINE_PATTERNS: Sequence[Tuple[str, str, FieldParser]] = (
    ("blank", r"", _none),
    ("error", r"Error", _none),
    # version / signature (#fb-version, #fb-signature); bootloader version (#fb-bootloader-version)
    ("version", r"Firmware version: (?P<v>.*)", _version),
    ("bootloader_version", r"BuildHAT bootloader version (?P<v>.*)", _version),
    ("signature", r"Firmware signature:(?P<hex>(?: [0-9A-F]{2})*)", _hex_bytes),
    # vin (#fb-vin)
    ("vin", r"(?P<v>\d+\.\d\d) V", _vin),
    # data lines (#fb-data-lines)
    ("mode_data", _P + rf"M(?P<m>\d+):(?P<vals>(?: +{_V})*)", _mode_data),
    ("combi_data", _P + rf"C(?P<i>\d+):(?P<vals>(?: +{_V})*)", _combi_data),
    ("var_data", _P + rf"V: (?P<v>{_F})", _var_data),
    # debug output (#fb-debug)
    ("pid_debug", _P + rf": pv=(?P<pv>{_F}) sp=(?P<sp>{_F}): e=(?P<e>{_F}) ie=(?P<ie>{_F}) "
                       rf"de=(?P<de>{_F}) cv=(?P<cv>{_F})", _pid_debug),
    ("data_debug", _P + r": DATA mode=(?P<m>[0-9a-fA-F]+) "
                        r"payload=(?P<payload>[0-9a-fA-F]{2}(?: [0-9a-fA-F]{2})*)?", _data_debug),
    ("signature_debug", _P + r": D5 signature=(?P<signature>[0-9A-Fa-f]+) id=(?P<id>\d+)", _with()),
    ("unknown_debug", _P + r": type=(?P<type>[0-9A-Fa-f]{2}) cmd=(?P<cmd>[0-9A-Fa-f]{2})  "
                           r"payload=(?P<payload>.*)", _with(phase="setup_info")),
    ("unknown_debug", _P + r" message type=(?P<type>[0-9A-Fa-f]{2})", _with(phase="setup")),
    ("unknown_debug", _P + r": data-phase message type (?P<type>[0-9A-Fa-f]{2}) payload=(?P<payload>.*)",
     _with(phase="data")),
    # list / device dump (#fb-list; also printed when an active device is established)
    ("list_port", _P + r": no device detected", _list_port("none")),
    ("connected_passive", _P + r": connected to passive ID (?P<id>\d+)", _list_port("passive")),
    ("list_port", _P + r": connected to active ID (?P<id>[0-9A-F]{2})", _list_port("active")),
    ("list_line", r"type (?P<type>[0-9A-F]{2})", _list_line("type")),
    ("list_line", r"  nmodes =(?P<value_dec>\d+)", _list_line("nmodes")),
    ("list_line", r"  nview  =(?P<value_dec>\d+)", _list_line("nview")),
    ("list_line", r"  baud   =(?P<value_dec>\d+)", _list_line("baud")),
    ("list_line", r"  hwver  =(?P<value>[0-9A-F]{8})", _list_line("hwver")),
    ("list_line", r"  swver  =(?P<value>[0-9A-F]{8})", _list_line("swver")),
    ("list_line", r"  M(?P<mode>\d+) (?P<name>.*) SI = (?P<symbol>.*)", _list_line("mode")),
    ("list_line", r"    format count=(?P<count>\d+) type=(?P<type_code>\d+) "
                  r"chars=(?P<chars>\d+) dp=(?P<dp>\d+)", _list_line("format")),
    ("list_line", rf"    RAW: (?P<raw0>{_H8}) (?P<raw1>{_H8})    PCT: (?P<pct0>{_H8}) (?P<pct1>{_H8})"
                  rf"    SI: (?P<si0>{_H8}) (?P<si1>{_H8})", _range_line),
    ("list_line", r"  C(?P<index>\d+): (?P<modes>M\d+(?:\+M\d+)*)", _list_line("combi")),
    ("list_line", rf"(?:     (?P<which>speed) PID|  (?P<which_>position) PID):(?P<vals>(?: {_H8}){{4}})",
     lambda m: {"field": (m.group("which") or m.group("which_")) + "_pid",
                "values": [int(v, 16) for v in m.group("vals").split()]}),
    # lines the HAT prints on its own (#fb-async)
    ("connecting", _P + r": connecting to active device", _port),
    ("baud", r"set baud rate to (?P<baud>\d+)", lambda m: {"baud": int(m.group("baud"))}),
    ("established", _P + r": established serial communication with active ID (?P<id>[0-9A-F]{2})",
     lambda m: {"port": _hexport(m.group("p")), "id": int(m.group("id"), 16)}),
    ("disconnected", _P + r": disconnected", _port),
    ("timeout", _P + r": timeout during (?P<phase>setup|data) phase: disconnecting", _with()),
    ("checksum_error", _P + r": checksum error: disconnecting", _port),
    ("framing_error", _P + r": framing error: disconnecting", _port),
    ("too_many_errors", _P + r": too many errors \((?P<framing>\d+)\+(?P<checksum>\d+)\): disconnecting",
     lambda m: {"port": _hexport(m.group("p")), "framing": int(m.group("framing")),
                "checksum": int(m.group("checksum"))}),
    ("button", _P + r": button (?P<state>pressed|released)",
     lambda m: {"port": _hexport(m.group("p")), "pressed": m.group("state") == "pressed"}),
    ("pulse_done", _P + r": pulse done", _port),
    ("ramp_done", _P + r": ramp done", _port),
    ("port_fault", r"Port power fault", _none),
    ("motor_fault", r"Motor power fault", _none),
    ("fault_dump", r" Port 4D 4E 4F", lambda m: {"header": True}),
    ("fault_dump", r"   (?P<p>[0-3]) (?P<flags>(?: [0-9A-F]{2}){3})", _fault_row),
    ("fault_read_error", r"Error reading fault flags", _none),
    ("mq_overrun", r"MQ overrun!", _none),
    ("deltat", r"deltat=(?P<hex>[0-9A-F]{8})", lambda m: {"ms": int(m.group("hex"), 16)}),
    # start-up banner (#fb-startup; the bootloader shares the first line)
    ("banner", r"Type help <RETURN> for help", _with(stage="help_hint")),
    ("banner", r"Initialising ports", _with(stage="initialising")),
    ("banner", r"Resetting drivers: (?P<digits>\d*)", _with(stage="resetting")),
    ("banner", r"Reading driver dumps: (?P<when>before|after) port_initdriver\(\): (?P<digits>\d*)",
     _with(stage="driver_dumps")),
    ("banner", r"Done initialising ports", _with(stage="done")),
    ("i2c_error", r"(?P<before>.*?)<(?P<error>generic I²C bus error|I²C bus timeout)>(?P<after>.*)", _with()),
    ("i2c_error", r"Attempting reset of I²C bus", _with(error="reset")),
    ("assertion", r"Assertion failed", _none),
    # bootloader messages (#fb-bootloader)
    ("bootloader_message", r"Image too large \(maximum (?P<max>\d+) bytes\)", _with(message="too_large")),
    ("bootloader_message", r"Timed out waiting for data", _with(message="data_timeout")),
    ("bootloader_message", r"Image received", _with(message="image_received")),
    ("bootloader_message", r"Checksum OK", _with(message="checksum_ok")),
    ("bootloader_message", r"Checksum failure", _with(message="checksum_failure")),
    ("bootloader_message", r"Incorrect signature length \(should be64 bytes\)",
     _with(message="bad_signature_length")),
    ("bootloader_message", r"Signature received", _with(message="signature_received")),
    ("bootloader_message", r"No image loaded", _with(message="no_image")),
    ("bootloader_message", r"Verifying image\.\.\.", _with(message="verifying")),
    ("bootloader_message", r"Verifying image length=(?P<length>\d+)(?P<bytes>(?: [0-9A-Fa-f]{1,2})*)",
     _with(message="verify_length")),
    ("bootloader_message", r"SHA256:", _with(message="sha256")),
    ("bootloader_message", r"Public key:", _with(message="public_key")),
    ("bootloader_message", r"Image verifed OK", _with(message="verified")),
    ("bootloader_message", r"Image verification failed", _with(message="verification_failed")),
    ("bootloader_message", r"Rebooting\.\.\.", _with(message="rebooting")),
    # the bootloader build of 2021-09-12 answered `version` with the bare number only (#fb-bootloader-version)
    ("bootloader_version", r"(?P<v>\d{10})", lambda m: dict(_version(m), bare=True)),
    ("hex_dump", r"(?P<hex>(?: [0-9A-Fa-f]{2})+)", _hex_bytes),
)

_COMPILED: List[Tuple[str, Pattern[str], FieldParser]] = [
    (kind, re.compile(rx, re.DOTALL), parse) for kind, rx, parse in LINE_PATTERNS]

KINDS: FrozenSet[str] = frozenset(
    {k for k, _r, _p in LINE_PATTERNS} | {"prompt", "bootloader_prompt", "echo", "help", "unknown"})
PORT_STATUS_KINDS: FrozenSet[str] = frozenset({"list_port", "connected_passive"})
#: Whole lines a HAT prints on its own, whatever the host is typing: streams and debug output,
#: device and fault events (FIRMWARE-BEHAVIOUR.md#fb-async, #fb-reporting, #fb-debug). With echo
#: on, one may come between any two bytes of an echo (line_splitter.py).
UNASKED_KINDS: FrozenSet[str] = frozenset({
    "mode_data", "combi_data", "var_data", "pid_debug", "data_debug", "signature_debug", "unknown_debug",
    "deltat", "connecting", "baud", "established", "connected_passive", "disconnected", "timeout",
    "checksum_error", "framing_error", "too_many_errors", "button", "pulse_done", "ramp_done", "port_fault",
    "motor_fault", "fault_dump", "mq_overrun"})


@lru_cache(maxsize=1)
def _help_lines() -> FrozenSet[str]:
    """Every help-text line of every release and of the bootloader (#fb-help, #fb-bootloader-commands)."""
    from ..protocol.profiles import bootloader_data, load_profiles
    lines = set()
    for p in load_profiles().values():
        lines.update(p.help_lines)
    lines.update(bootloader_data().get("help_text", ()))
    lines.discard("")  # the empty line inside the help text is a plain blank line
    return frozenset(lines)


def decode(raw: bytes) -> str:
    """Lenient decoding: UTF-8 where valid (help text has – and Δ), else one char per byte."""
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


# Every row's pattern in one alternation (group names dropped: they repeat across rows), so a
# line no Build HAT prints is turned away by one match instead of one per row; a device
# flooding 3,000 such lines/s cost the session a core (issue 13).
_ANY_ROW: Pattern[str] = re.compile(
    "|".join(f"(?:{re.sub(r'[(][?]P<[A-Za-z_][A-Za-z0-9_]*>', '(?:', rx)})" for _k, rx, _p in LINE_PATTERNS),
    re.DOTALL)


@lru_cache(maxsize=8192)
def _row_of(text: str) -> int:
    """Index in ``_COMPILED`` of the first row that matches ``text`` and whose values parse
    (-1: none). Cached because a host sees the same lines over and over (fence answers,
    prompts, ``Error``): trying every pattern for each line was the fuzzer's hottest path
    (H10, ``make bench``). Only the row is cached; fields are parsed afresh for every event."""
    if _ANY_ROW.fullmatch(text) is None:
        return -1
    for i, (_kind, rx, parse) in enumerate(_COMPILED):
        m = rx.fullmatch(text)
        if m:
            try:
                parse(m)
            except ValueError:
                continue  # looked like this kind but its values do not parse: try the next row
            return i
    return -1


def classify(raw: Union[bytes, str], t: float = 0.0) -> Event:
    """The event for one complete line (without its CRLF)."""
    if isinstance(raw, str):
        text, data = raw, raw.encode("utf-8")
    else:
        data, text = bytes(raw), decode(raw)
    row = _row_of(text)
    if row >= 0:
        kind, rx, parse = _COMPILED[row]
        m = rx.fullmatch(text)
        assert m is not None             # _row_of found this row matching
        return Event(kind, text, data, t, parse(m))
    if text in _help_lines():
        return Event("help", text, data, t, {})
    return Event("unknown", text, data, t, {})


@lru_cache(maxsize=8192)
def line_kind(raw: bytes) -> str:
    """``classify(raw).kind``, cached per line: the fuzzer notes the kind of every line it
    reads (H10 profile), and for that needs no Event and no parsed fields."""
    return classify(raw).kind
