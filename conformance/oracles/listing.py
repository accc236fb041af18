"""The ``list`` dump: a grammar for the whole output and a renderer from the device catalogue.

Layout from FIRMWARE-BEHAVIOUR.md#fb-list (identical R1-R7) and devices.json ``_meta.list_rendering``.
The renderer builds a device's block from the catalogue's *fields* (modes, ranges, combi
masks, PID constants), not from its pre-rendered ``hat_list_lines``, so the two can be
checked against each other and against the wire.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Dict, List, Optional

__all__ = ["ListError", "PortEntry", "parse_list", "render_active", "render_port", "range_hex"]


class ListError(ValueError):
    """The dump does not follow the grammar; says which line and what was expected."""


@dataclass
class Mode:
    index: int
    name: str
    symbol: str
    count: int
    type: int
    chars: int
    dp: int
    ranges: Dict[str, tuple]          # RAW/PCT/SI -> (min, max) as printed integers


@dataclass
class PortEntry:
    port: int
    kind: str                         # "empty", "passive", "active"
    id: Optional[int] = None
    nmodes: Optional[int] = None
    nview: Optional[int] = None
    baud: Optional[int] = None
    hwver: Optional[str] = None
    swver: Optional[str] = None
    modes: List[Mode] = field(default_factory=list)
    combis: List[List[int]] = field(default_factory=list)
    speed_pid: Optional[tuple] = None
    position_pid: Optional[tuple] = None
    lines: List[str] = field(default_factory=list)


_HEX8 = r"([0-9A-F]{8})"
_HEADER = re.compile(r"P([0-3]): (?:(no device detected)|connected to passive ID ([1-9][0-9]*)"
                     r"|connected to active ID ([0-9A-F]{2}))")
_ACTIVE_FIELDS = [
    ("type", re.compile(r"type ([0-9A-F]{2})")),
    ("nmodes", re.compile(r"  nmodes =([0-9]+)")),
    ("nview", re.compile(r"  nview  =([0-9]+)")),
    ("baud", re.compile(r"  baud   =([0-9]+)")),
    ("hwver", re.compile(r"  hwver  =" + _HEX8)),
    ("swver", re.compile(r"  swver  =" + _HEX8)),
]
# An empty symbol keeps the space after '=' (FIRMWARE-BEHAVIOUR.md#fb-list): "SI = " then the symbol.
_MODE = re.compile(r"  M([0-9]|1[0-5]) (.+) SI = (.*)")
_FORMAT = re.compile(r"    format count=([0-9]+) type=([0-3]) chars=([0-9]+) dp=([0-9]+)")
_RANGE = re.compile(rf"    RAW: {_HEX8} {_HEX8}    PCT: {_HEX8} {_HEX8}    SI: {_HEX8} {_HEX8}")
_COMBI = re.compile(r"  C([0-7]): (M(?:[0-9]|1[0-5])(?:\+M(?:[0-9]|1[0-5]))*)")
_SPEED_PID = re.compile(r"     speed PID: " + " ".join([_HEX8] * 4))
_POS_PID = re.compile(r"  position PID: " + " ".join([_HEX8] * 4))


def _full(rx: re.Pattern[str], line: str, where: str):
    m = rx.fullmatch(line)
    if not m:
        raise ListError(f"{where}: expected {rx.pattern!r}, got {line!r}")
    return m


def parse_list(lines: List[str]) -> List[PortEntry]:
    """Parse the complete output of ``list`` (lines without CRLF): exactly ports 0..3 in order."""
    out: List[PortEntry] = []
    i = 0
    for port in range(4):
        if i >= len(lines):
            raise ListError(f"output ends before the entry of port {port}")
        m = _full(_HEADER, lines[i], f"line {i + 1}")
        if int(m.group(1)) != port:
            raise ListError(f"line {i + 1}: expected port {port} next, got {lines[i]!r}")
        start = i
        i += 1
        if m.group(2):
            entry = PortEntry(port, "empty")
        elif m.group(3):
            entry = PortEntry(port, "passive", id=int(m.group(3)))
        else:
            entry = PortEntry(port, "active", id=int(m.group(4), 16))
            i = _parse_active(lines, i, entry)
        entry.lines = lines[start:i]
        out.append(entry)
    if i != len(lines):
        raise ListError(f"unexpected lines after port 3: {lines[i:]!r}")
    return out


def _parse_active(lines: List[str], i: int, entry: PortEntry) -> int:
    def line(k: int) -> str:
        if k >= len(lines):
            raise ListError(f"P{entry.port}: output ends inside the active device block")
        return lines[k]

    for name, rx in _ACTIVE_FIELDS:
        m = _full(rx, line(i), f"line {i + 1} ({name})")
        value = m.group(1)
        if name == "type":
            if int(value, 16) != entry.id:
                raise ListError(f"line {i + 1}: type {value} differs from the ID {entry.id:02X}")
        elif name in ("hwver", "swver"):
            setattr(entry, name, value)
        else:
            setattr(entry, name, int(value))
        i += 1
    while (m := _MODE.fullmatch(line(i))) is not None:
        f = _full(_FORMAT, line(i + 1), f"line {i + 2} (format)")
        r = _full(_RANGE, line(i + 2), f"line {i + 3} (ranges)")
        vals = [int(x, 16) for x in r.groups()]
        entry.modes.append(Mode(int(m.group(1)), m.group(2), m.group(3), *(int(x) for x in f.groups()),
                                ranges={"RAW": tuple(vals[0:2]), "PCT": tuple(vals[2:4]),
                                        "SI": tuple(vals[4:6])}))
        i += 3
    indexes = [mode.index for mode in entry.modes]
    if indexes != sorted(set(indexes)):
        raise ListError(f"P{entry.port}: modes not in ascending order: {indexes}")
    while (combi := _COMBI.fullmatch(line(i))) is not None:
        bits = [int(x) for x in combi.group(2).replace("M", "").split("+")]
        if bits != sorted(set(bits)):
            raise ListError(f"line {i + 1}: combi modes not ascending: {line(i)!r}")
        entry.combis.append(bits)
        i += 1
    entry.speed_pid = tuple(int(x, 16) for x in _full(_SPEED_PID, line(i), f"line {i + 1}").groups())
    entry.position_pid = tuple(int(x, 16) for x in _full(_POS_PID, line(i + 1), f"line {i + 2}").groups())
    return i + 2


def range_hex(value: float) -> str:
    """A float range limit as the RP2040's float->uint32 prints it: truncate, saturate."""
    if value != value or value <= 0:
        return "00000000"
    if value >= 2**32:
        return "FFFFFFFF"
    return f"{int(value):08X}"


def render_active(port: int, device: dict) -> List[str]:
    """The ``list`` block for a catalogue device entry (devices.json) on ``port``."""
    tid = int(device["type_id"]) if "type_id" in device else int(device["type_hex"], 16)
    lines = [f"P{port}: connected to active ID {tid:02X}", f"type {tid:02X}",
             f"  nmodes ={device['nmodes']}", f"  nview  ={device['nview']}",
             f"  baud   ={device['baud']}", f"  hwver  ={device['hwver']}", f"  swver  ={device['swver']}"]
    for mode in sorted(device["modes"], key=lambda m: m["index"]):
        if not mode["name"]:
            continue
        fmt = mode["format"]
        lines.append(f"  M{mode['index']} {mode['name']} SI = {mode['symbol']}")
        lines.append(f"    format count={fmt['count']} type={fmt['type']} "
                     f"chars={fmt['chars']} dp={fmt['dp']}")
        lines.append("    " + "    ".join(
            f"{label}: {range_hex(mode[key + '_min'])} {range_hex(mode[key + '_max'])}"
            for label, key in (("RAW", "raw"), ("PCT", "pct"), ("SI", "si"))))
    for i, mask in enumerate(device.get("combi_masks", [])):
        if mask:
            lines.append(f"  C{i}: " + "+".join(f"M{b}" for b in range(16) if mask >> b & 1))
    speed = device.get("speed_pid") or [0, 0, 0, 0]
    position = device.get("position_pid") or [0, 0, 0, 0]
    lines.append("     speed PID: " + " ".join(f"{v & 0xFFFFFFFF:08X}" for v in speed))
    lines.append("  position PID: " + " ".join(f"{v & 0xFFFFFFFF:08X}" for v in position))
    return lines


def render_port(port: int, spec: Optional[tuple], catalogue: dict) -> List[str]:
    """Expected lines for one port given ("active", id) / ("passive", id) / None."""
    if spec is None:
        return [f"P{port}: no device detected"]
    kind, ident = spec
    if kind == "passive":
        return [f"P{port}: connected to passive ID {ident}"]
    return render_active(port, catalogue[f"0x{ident:02X}"])
