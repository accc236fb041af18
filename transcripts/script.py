"""Scenario scripts (docs/formats/SCENARIO-SCRIPT.md): the parser.

A script is a list of actions run in order from t = 0 ms. Host actions (``>``, ``>raw``)
and ``@wait`` work on any target; world actions (``@plug``, ``@data``, faults, ...) need a
target with the matching control capability (see :attr:`Action.capability`). Running a
script lives in :mod:`.script_runner`.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple, Union

from ..protocol.devices import DEFAULT_LAYOUT, parse_device_spec

__all__ = ["Action", "Script", "ScriptError", "parse_script", "load_script", "unescape_raw",
           "escape_raw", "WORLD_ACTIONS", "format_action"]

# The world actions and the control capability each needs (one capability per action name).
WORLD_ACTIONS = ("plug", "unplug", "data", "motorfault", "portfault", "button", "adc", "rate", "hold", "pos")


class ScriptError(ValueError):
    """A script line that does not follow the format; carries the file and line number."""

    def __init__(self, message: str, lineno: int = 0, source: str = "<script>"):
        self.lineno, self.source = lineno, source
        super().__init__(f"{source}:{lineno}: {message}" if lineno else message)


@dataclass(frozen=True)
class Action:
    """One script line. ``kind`` is ``send``, ``wait`` or a world action name."""

    kind: str
    args: Tuple = ()
    data: bytes = b""        # for send: the exact bytes (CR included for '>')
    lineno: int = 0
    text: str = ""           # the source line

    @property
    def capability(self) -> Optional[str]:
        """The control capability a target needs for this action (None: host or time)."""
        if self.kind == "portfault" and len(self.args) > 1:
            return "faultpulse"          # a fault timed by the HAT's clock, not the host's
        return self.kind if self.kind in WORLD_ACTIONS else None


@dataclass
class Script:
    name: str = ""
    devices: Dict[int, Optional[tuple]] = field(default_factory=lambda: dict(DEFAULT_LAYOUT))
    actions: List[Action] = field(default_factory=list)
    source: str = "<script>"
    explicit_devices: Dict[int, Optional[tuple]] = field(default_factory=dict)

    @property
    def capabilities(self) -> set:
        """Every control capability the script needs (devices given with @device count as 'plug')."""
        caps = {a.capability for a in self.actions if a.capability}
        if self.explicit_devices:
            caps.add("layout")
        return caps

    @property
    def duration_ms(self) -> float:
        """Scripted time: the sum of the waits, plus the 20 ms tail the format adds."""
        return sum(a.args[0] for a in self.actions if a.kind == "wait") + 20.0


_ESCAPES = {"r": b"\r", "n": b"\n", "t": b"\t", "b": b"\b", "\\": b"\\", "s": b" "}


def unescape_raw(text: str) -> bytes:
    """Decode a ``>raw`` argument: ``\\r \\n \\t \\b \\\\ \\s \\xHH``; other text as UTF-8."""
    out = bytearray()
    i = 0
    while i < len(text):
        c = text[i]
        if c != "\\":
            out += c.encode("utf-8")
            i += 1
            continue
        if i + 1 >= len(text):
            raise ValueError("a lone backslash ends the line")
        e = text[i + 1]
        if e in _ESCAPES:
            out += _ESCAPES[e]
            i += 2
        elif e == "x":
            hh = text[i + 2:i + 4]
            if len(hh) != 2 or any(ch not in "0123456789abcdefABCDEF" for ch in hh):
                raise ValueError(f"\\x needs two hex digits, got {hh!r}")
            out.append(int(hh, 16))
            i += 4
        else:
            raise ValueError(f"unknown escape \\{e} (known: \\r \\n \\t \\b \\\\ \\s \\xHH)")
    return bytes(out)


def escape_raw(data: bytes) -> str:
    """The inverse of :func:`unescape_raw` (printable ASCII kept, spaces as ``\\s``)."""
    rev = {v[0]: "\\" + k for k, v in _ESCAPES.items()}
    return "".join(rev[b] if b in rev else (chr(b) if 0x21 <= b < 0x7F else f"\\x{b:02X}") for b in data)


def _int(tok: str, what: str, lo: Optional[int] = None, hi: Optional[int] = None) -> int:
    try:
        v = int(tok, 0) if tok.lower().startswith("0x") else int(tok)
    except ValueError:
        raise ValueError(f"{what} must be an integer, got {tok!r}") from None
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{what} must be in {lo}..{hi}, got {v}")
    return v


def _port(tok: str) -> int:
    return _int(tok, "port", 0, 3)


def _flag(tok: str, what: str) -> int:
    if tok not in ("0", "1"):
        raise ValueError(f"{what} must be 0 or 1, got {tok!r}")
    return int(tok)


def _hexbytes(toks: List[str], what: str) -> bytes:
    try:
        vals = [int(t, 16) for t in toks]
    except ValueError:
        raise ValueError(f"{what} must be hex bytes (HH HH ...), got {' '.join(toks)!r}") from None
    if any(not 0 <= v <= 0xFF for v in vals):
        raise ValueError(f"{what}: every byte must be 00..FF")
    return bytes(vals)


def _parse_world(word: str, toks: List[str]) -> tuple:
    n = len(toks)
    if word in ("plug",):
        if n < 2:
            raise ValueError("@plug needs: P SPEC")
        return (_port(toks[0]), parse_device_spec(" ".join(toks[1:])))
    if word == "unplug":
        if n != 1:
            raise ValueError("@unplug needs: P")
        return (_port(toks[0]),)
    if word == "data":
        if n < 3:
            raise ValueError("@data needs: P M HH HH ... (or P M auto)")
        port, mode = _port(toks[0]), _int(toks[1], "mode", 0, 15)
        if n == 3 and toks[2].lower() == "auto":
            return (port, mode, None)
        return (port, mode, _hexbytes(toks[2:], "@data payload"))
    if word == "motorfault":
        if not toks:
            raise ValueError("@motorfault needs: 1 P [F4D F4E F4F] or 0 [P]")
        on = _flag(toks[0], "@motorfault state")
        if on:
            if n not in (2, 5):
                raise ValueError("@motorfault 1 needs: P [F4D F4E F4F]")
            flags = _hexbytes(toks[2:], "@motorfault flags") if n == 5 else bytes([1, 0, 0])
            return (1, _port(toks[1]), flags)
        if n > 2:
            raise ValueError("@motorfault 0 takes at most a port")
        return (0, _port(toks[1]) if n == 2 else None, None)
    if word == "portfault":
        if n == 2 and toks[0] == "1":
            # a pulse: low for MS ms of HAT time, then high (timed by the HAT's clock, not the host's)
            return (1, _int(toks[1], "@portfault pulse (ms)", 1, 10**6))
        if n != 1:
            raise ValueError("@portfault needs: 1|0, or 1 MS (a pulse of MS ms)")
        return (_flag(toks[0], "@portfault state"),)
    if word == "button":
        if n != 2:
            raise ValueError("@button needs: P 0|1")
        return (_port(toks[0]), _flag(toks[1], "@button state"))
    if word == "adc":
        if n != 1:
            raise ValueError("@adc needs: RAW")
        return (_int(toks[0], "ADC reading", 0, 4095),)
    if word == "rate":
        if n != 2:
            raise ValueError("@rate needs: P MS")
        return (_port(toks[0]), _int(toks[1], "rate (ms)", 1, 10**6))
    if word == "hold":
        if n != 2:
            raise ValueError("@hold needs: P 0|1")
        return (_port(toks[0]), _flag(toks[1], "@hold state"))
    if word == "pos":
        if n != 2:
            raise ValueError("@pos needs: P DEG")
        try:
            deg = float(toks[1])
        except ValueError:
            raise ValueError(f"@pos position must be a number, got {toks[1]!r}") from None
        return (_port(toks[0]), deg)
    raise ValueError(f"unknown action @{word}")


def parse_world_action(line: str) -> Action:
    """Parse one world-action line (``@plug 1 0x30``); used by control channels too."""
    s = line.strip()
    if not s.startswith("@"):
        raise ValueError(f"a world action starts with @, got {s!r}")
    word, *toks = s[1:].split()
    if word not in WORLD_ACTIONS:
        raise ValueError(f"unknown world action @{word} (known: {', '.join('@' + w for w in WORLD_ACTIONS)})")
    return Action(kind=word, args=_parse_world(word, toks), text=s)


def parse_script(text: str, source: str = "<script>") -> Script:
    script = Script(source=source)
    started = False  # @device is only allowed before the first other action
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.rstrip("\r\n")
        stripped = line.strip()
        if not stripped or stripped.startswith(";;"):
            continue
        try:
            if line.startswith(">"):
                started = True
                if line == ">":
                    data = b"\r"
                elif line.startswith(">raw ") or line == ">raw":
                    data = unescape_raw(line[5:])
                elif line.startswith("> "):
                    data = line[2:].encode("utf-8") + b"\r"
                else:
                    raise ValueError("'>' must be followed by a space and the text (or be alone)")
                script.actions.append(Action("send", (), data, lineno, line))
                continue
            if not stripped.startswith("@"):
                raise ValueError("a line is '> TEXT', '>raw ESCAPED', an @action, ';; comment' or blank")
            word, *toks = stripped[1:].split()
            if word == "name":
                script.name = stripped[len("@name"):].strip()
            elif word == "device":
                if started:
                    raise ValueError("@device sets the start-up layout and must come before other actions")
                if len(toks) < 2:
                    raise ValueError("@device needs: P SPEC")
                port, spec = _port(toks[0]), parse_device_spec(" ".join(toks[1:]))
                script.devices[port] = spec
                script.explicit_devices[port] = spec
            elif word == "wait":
                started = True
                if len(toks) != 1:
                    raise ValueError("@wait needs: N (milliseconds)")
                try:
                    ms = float(toks[0])
                except ValueError:
                    raise ValueError(f"@wait takes milliseconds, got {toks[0]!r}") from None
                if ms < 0:
                    raise ValueError("@wait cannot be negative")
                script.actions.append(Action("wait", (ms,), b"", lineno, line))
            else:
                started = True
                act = parse_world_action(stripped)
                script.actions.append(Action(act.kind, act.args, b"", lineno, line))
        except (ValueError, KeyError) as exc:
            msg = exc.args[0] if exc.args else str(exc)
            raise ScriptError(str(msg), lineno, source) from None
    return script


def load_script(path: Union[str, os.PathLike]) -> Script:
    """Read and parse a script file; text that is not UTF-8 is a ScriptError naming its line."""
    with open(path, "rb") as fh:
        raw = fh.read()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        why = f"not UTF-8 text ({exc.reason} at byte {exc.start})"
        raise ScriptError(why, line, os.fspath(path)) from None
    return parse_script(text, os.fspath(path))


def format_action(action: Action) -> str:
    """A script line for an action (used to write findings as scripts)."""
    if action.kind == "send":
        d = action.data
        if d.endswith(b"\r") and b"\r" not in d[:-1] and all(0x20 <= b < 0x7F for b in d[:-1]) \
                and not d[:-1].endswith(b" "):
            return "> " + d[:-1].decode() if len(d) > 1 else ">"
        return ">raw " + escape_raw(d)
    if action.kind == "wait":
        ms = action.args[0]
        return f"@wait {int(ms) if ms == int(ms) else ms}"
    return action.text or f"@{action.kind} " + " ".join(str(a) for a in action.args)
