"""Planted faults: the real emulator with one deliberate bug, to prove the fuzzer finds bugs.

Each class wraps ``buildhat_conformance.emulator.Emulator`` (the same Python API, so it plugs into
``InProcessTarget(factory=...)``) and changes what crosses the command port in one way:

- :class:`HangsOnList`: once a line whose first word resolves to ``list`` arrives, the HAT stops
  answering anything (a firmware hang);
- :class:`WrongCoast`: a line whose first word resolves to ``coast`` also prints ``Error`` (a
  command answered wrongly);
- :class:`DropsBytes`: every 1000th output byte is lost (a lossy link or TX ring);
- :class:`MutesReports`: mode data lines (``P<p>M<m>: ...``) are never printed;
- :class:`IgnoresPlimit`: the motor driver is driven as if plimit were 1 (a drive-path bug, seen
  only through the emulator's drive events);
- :class:`CombiAsMode`: combi data lines come out as mode data (``P<p>C<i>:`` as ``P<p>M<i>:``, a
  printer that ignores the combi table).

The same faults work as a byte proxy in front of ``buildhat-emulator --stdio`` (``proxy.py``),
for ``cmd:`` targets. The trigger logic is :class:`FaultFilter`, shared by both.
"""
from __future__ import annotations

import re
from typing import Optional

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.fuzz.findings.finding_scripts import split_lines

__all__ = ["FaultFilter", "HangsOnList", "WrongCoast", "DropsBytes", "MutesReports", "IgnoresPlimit",
           "CombiAsMode", "FAULTS"]


def _first_word(line: bytes) -> bytes:
    return line.lstrip(b" ;").split(b" ")[0].split(b";")[0]


def _resolves_to(word: bytes, name: bytes, shortest: bytes) -> bool:
    return len(word) >= len(shortest) and name.startswith(word)


class FaultFilter:
    """The fault as a filter on host lines and HAT output (no emulator knowledge)."""

    def __init__(self, kind: str):
        if kind not in ("hang", "wrong", "drop", "mute", "plimit", "combiform"):
            raise ValueError(f"unknown planted fault {kind!r} (hang, wrong, drop, mute, plimit, combiform)")
        self.kind = kind
        self.hung = False
        self.sent = 0                 # output bytes passed so far (for 'drop')
        self.pending = bytearray()    # host bytes since the last CR

    def host_lines(self, data: bytes):  # type: ignore[no-untyped-def]
        """Split host bytes into chunks that end at CR (plus a tail)."""
        return split_lines(data)

    def triggered(self, chunk: bytes) -> bool:
        """Does this CR-terminated chunk set the fault off?"""
        if not chunk.endswith(b"\r"):
            self.pending += chunk
            return False
        line = bytes(self.pending) + chunk[:-1]
        self.pending.clear()
        word = _first_word(line)
        if self.kind == "hang":
            return _resolves_to(word, b"list", b"l")
        if self.kind == "wrong":
            return _resolves_to(word, b"coast", b"co")
        return False

    def output(self, data: bytes, wrong_line: bool = False) -> bytes:
        if self.hung:
            return b""
        if wrong_line:
            i = data.find(b"\r\n")
            if i >= 0:
                data = data[:i + 2] + b"Error\r\n" + data[i + 2:]
        if self.kind == "mute":
            data = re.sub(rb"P[0-3]M\d+:[^\r]*\r\n", b"", data)
        if self.kind == "combiform":
            data = re.sub(rb"(P[0-3])C(\d+:)", rb"\1M\2", data)
        if self.kind == "drop":
            kept = bytearray()
            for b in data:
                self.sent += 1
                if self.sent % 1000:
                    kept.append(b)
            data = bytes(kept)
        return data


class _Planted:
    """An Emulator with a :class:`FaultFilter` on its command port."""

    kind = ""

    def __init__(self, **kwargs):
        self.emu = Emulator(**kwargs)
        self.fault = FaultFilter(self.kind)
        self._out = bytearray()

    def write(self, data: bytes) -> None:
        for chunk in self.fault.host_lines(bytes(data)):
            if self.fault.hung:
                return
            fire = self.fault.triggered(chunk)
            self.emu.write(chunk)
            out = self.emu.read()
            if fire and self.kind == "hang":
                self.fault.hung = True
                return
            self._out += self.fault.output(out, wrong_line=fire and self.kind == "wrong")

    def read(self) -> bytes:
        self._out += self.fault.output(self.emu.read())
        out = bytes(self._out)
        self._out.clear()
        return out

    def boot(self, *args, **kwargs) -> int:
        n = self.emu.boot(*args, **kwargs)
        self.fault.sent = 0
        return n

    def __getattr__(self, name: str):  # type: ignore[no-untyped-def]
        # step, advance, now, world, hat, on_event ...: the real emulator's. (Not during copying,
        # when 'emu' does not exist yet.)
        if name.startswith("__") or name == "emu":
            raise AttributeError(name)
        return getattr(self.emu, name)


class HangsOnList(_Planted):
    kind = "hang"


class WrongCoast(_Planted):
    kind = "wrong"


class DropsBytes(_Planted):
    kind = "drop"


class MutesReports(_Planted):
    kind = "mute"


class IgnoresPlimit(_Planted):
    kind = "plimit"

    def on_event(self, callback) -> None:  # type: ignore[no-untyped-def]
        def skewed(event):  # type: ignore[no-untyped-def]
            if event.get("dir") == "pwm" and isinstance(event.get("value"), int) and event["value"]:
                event = dict(event, value=max(-255, min(255, event["value"] * 10)))
            callback(event)
        self.emu.on_event(skewed)


class CombiAsMode(_Planted):
    kind = "combiform"


FAULTS = {"hang": HangsOnList, "wrong": WrongCoast, "drop": DropsBytes, "mute": MutesReports,
          "plimit": IgnoresPlimit, "combiform": CombiAsMode}


def planted(kind: str) -> Optional[type]:
    return FAULTS.get(kind)
