"""The command language as data, built from a profile's command table
(docs/FIRMWARE-BEHAVIOUR.md#fb-matching, #fb-arguments, #fb-commands).

The argument signatures below are a transcription of the clamping table (fb-clamping) and the command
list (fb-commands), written in a small notation so they read like the help text:

- ``name:kind[:lo:hi]`` one argument; ``kind`` is one of :data:`ARG_KINDS`; ``lo``/``hi`` is the
  range the firmware clamps to (the fuzzer aims at and just past these boundaries);
- ``*N(...)`` a group read up to N times (``combi`` pairs, ``write1`` payload);
- a bare word (``square``) is a fixed keyword of the form;
- ``<svar>`` / ``<pid>`` expand to the sensor-variable block and the per-profile PID list.

Which commands exist, their matching order and the ``set`` keywords come from the profile, never
from a version test; the PID length and ``set var`` come from ``Profile.features``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple, Union

from ...protocol.profiles import Profile, get_profile

__all__ = ["ARG_KINDS", "Arg", "Repeat", "Form", "CommandRule", "Grammar", "grammar_for",
           "resolving_prefixes", "SIGNATURES"]

# unsigned: digits only; signed: optional +/- then digits; float: sign, d / d. / .d / d.d, no
# exponent; hex: one or more hex digits (low 8 bits kept); format: u1 s1 u2 s2 u4 s4 f4 (fb-numbers).
ARG_KINDS = ("unsigned", "signed", "float", "hex", "format")
FORMATS = ("u1", "s1", "u2", "s2", "u4", "s4", "f4")

_SVAR = "port:unsigned:0:3 mode:unsigned:0:15 offset:unsigned:0:127 format:format scale:float unwrap:float"
_GAINS = "Kp:float Ki:float Kd:float windup:float"
_WAVE = "min:float max:float period:float:0.02:1e30 phase:float:0:1"

# Command -> its forms (fb-commands). A form is one line of the help text's synopsis.
SIGNATURES: Dict[str, Tuple[str, ...]] = {
    "help": ("",), "?": ("",), "clear_faults": ("",),
    "port": ("port:unsigned:0:3",),
    "list": ("",),
    "ledmode": ("ledmode:signed:-1:3",),
    "pwm": ("",), "coast": ("",), "off": ("",), "on": ("",), "vin": ("",),
    "pid": ("<pid>",), "pid_diff": ("<pid>",),
    "set": ("setpoint:float", "<waves>", "var min:float max:float slope:float offset:float <svar>"),
    "bias": ("bias:float:0:1",),
    "pwmparams": ("pwmthresh:float:0:1 minpwm:float:0:1",),
    "plimit": ("limit:float:0:1",), "port_plimit": ("limit:float:0:1",),
    "select": ("", "mode:signed:0:15", "mode:signed:0:15 offset:signed:0:127 format:format"),
    "selonce": ("mode:signed:0:15", "mode:signed:0:15 offset:signed:0:127 format:format"),
    "selrate": ("rate:signed:0:1000000000",),
    "combi": ("index:signed:0:7", "index:signed:0:7 *15(mode:signed:0:15 dataset:signed:0:15)"),
    "write1": ("header:hex:0:255 *128(byte:hex:0:255)",),
    "write2": ("header:hex:0:255 header2:hex:0:255 *128(byte:hex:0:255)",),
    # Any non-zero echo enables echo and the prompt; debug is a bitmask (fb-debug).
    "echo": ("echo:signed:0:1",), "debug": ("debug:signed:0:63",),
    "version": ("",), "signature": ("",),
}

# The set keywords whose four numbers are a waveform; pulse/ramp read their 4th number too
# (fb-doc-pulse-ramp).
_WAVE_FORMS = {"square": _WAVE, "sine": _WAVE, "triangle": _WAVE,
               "pulse": "during:float after:float length:float:0.02:1e30 ignored:float:0:1",
               "ramp": "from:float to:float duration:float:0.02:1e30 phase:float:0:1"}


@dataclass(frozen=True)
class Arg:
    name: str
    kind: str
    lo: Optional[float] = None
    hi: Optional[float] = None


@dataclass(frozen=True)
class Repeat:
    group: Tuple[Arg, ...]
    max: int


Item = Union[Arg, Repeat, str]  # str: a fixed keyword


@dataclass(frozen=True)
class Form:
    production: str              # e.g. "set.square", "select.var": a coverage unit
    items: Tuple[Item, ...]

    @property
    def args(self) -> Tuple[Arg, ...]:
        out: List[Arg] = []
        for it in self.items:
            if isinstance(it, Arg):
                out.append(it)
            elif isinstance(it, Repeat):
                out.extend(it.group)
        return tuple(out)


@dataclass(frozen=True)
class CommandRule:
    name: str
    forms: Tuple[Form, ...]
    prefixes: Tuple[str, ...]    # every abbreviation that resolves to this command, shortest first


class Grammar:
    """The command rules of one release, in the firmware's matching order.

    A plain class (not a dataclass) so that Hypothesis prints strategies built on it as
    ``grammar_for('R7')`` rather than the whole profile.
    """

    def __init__(self, profile: Profile, commands: Tuple[CommandRule, ...], set_keywords: Tuple[str, ...]):
        self.profile = profile
        self.commands = commands
        self.set_keywords = set_keywords

    def __repr__(self) -> str:      # short: Hypothesis prints strategies that take a grammar
        return f"grammar_for({self.profile.name!r})"

    def __hash__(self) -> int:
        return hash((self.profile.number, self.profile.name))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Grammar) and (other.profile.number, other.profile.name) == (
            self.profile.number, self.profile.name)

    def rule(self, name: str) -> CommandRule:
        for r in self.commands:
            if r.name == name:
                return r
        raise KeyError(f"{self.profile.name} has no command {name!r}")

    @property
    def productions(self) -> Tuple[str, ...]:
        return tuple(f.production for r in self.commands for f in r.forms)

    @property
    def unknown_words(self) -> Tuple[str, ...]:
        """Command names of other releases that this one rejects (e.g. ``bias`` on R6+)."""
        return tuple(sorted(set(SIGNATURES) - set(self.profile.commands)))


def resolving_prefixes(name: str, table: Tuple[str, ...]) -> Tuple[str, ...]:
    """Prefixes of ``name`` that the first-match rule (fb-matching) resolves to ``name``."""
    out = []
    for n in range(1, len(name) + 1):
        p = name[:n]
        first = next(c for c in table if c.startswith(p))
        if first == name:
            out.append(p)
    return tuple(out)


_ARG_RE = re.compile(r"^(\w+):(\w+)(?::([^:]+):([^:]+))?$")


def _parse_arg(text: str) -> Arg:
    m = _ARG_RE.match(text)
    if not m or m.group(2) not in ARG_KINDS:
        raise ValueError(f"bad argument spec {text!r}")
    lo = float(m.group(3)) if m.group(3) is not None else None
    hi = float(m.group(4)) if m.group(4) is not None else None
    return Arg(m.group(1), m.group(2), lo, hi)


def _parse_items(text: str) -> Tuple[Item, ...]:
    items: List[Item] = []
    for rep in re.finditer(r"\*(\d+)\(([^)]*)\)|(\S+)", text):
        if rep.group(1):
            group = tuple(_parse_arg(t) for t in rep.group(2).split())
            items.append(Repeat(group, int(rep.group(1))))
        elif ":" in rep.group(3):
            items.append(_parse_arg(rep.group(3)))
        else:
            items.append(rep.group(3))
    return tuple(items)


def _pid_spec(profile: Profile) -> str:
    # R1-R5: pvport pvmode pvoffset pvformat pvscale pvunwrap Kp Ki Kd windup (10);
    # R6+: <svar> Kp Ki Kd windup deadzone (11), the same first six fields.
    spec = f"{_SVAR} {_GAINS}"
    extra = int(profile.feature("pid_numbers")) - 10
    return spec + " deadzone:float" * extra


def _forms(name: str, profile: Profile) -> Tuple[Form, ...]:
    forms: List[Form] = []
    for spec in SIGNATURES[name]:
        if spec == "<waves>":
            for kw in profile.set_keywords:
                if kw in _WAVE_FORMS:
                    forms.append(Form(f"{name}.{kw}", (kw,) + _parse_items(_WAVE_FORMS[kw])))
            continue
        if spec.startswith("var ") and "var" not in profile.set_keywords:
            continue
        text = spec.replace("<svar>", _SVAR).replace("<pid>", _pid_spec(profile))
        items = _parse_items(text)
        words = [it for it in items if isinstance(it, str)]
        n_args = sum(1 for it in items if not isinstance(it, str))
        label = ".".join([name] + words) if words else (
            name if len(SIGNATURES[name]) == 1 else f"{name}.{n_args}")
        forms.append(Form(label, items))
    return tuple(forms)


_CACHE: Dict[Tuple[int, str], Grammar] = {}


def grammar_for(profile: Union[Profile, str, int, None] = None) -> Grammar:
    """The grammar of one release (a :class:`Profile`, ``R7``, a version number or ``latest``)."""
    if not isinstance(profile, Profile):
        profile = get_profile(profile)
    key = (profile.number, profile.name)
    if key not in _CACHE:
        _CACHE[key] = _build(profile)
    return _CACHE[key]


def _build(profile: Profile) -> Grammar:
    missing = [c for c in profile.commands if c not in SIGNATURES]
    if missing:
        raise KeyError(f"{profile.name}: no argument signature for {missing}; "
                       "add it to fuzz/inputs/grammar.py")
    rules = tuple(CommandRule(c, _forms(c, profile), resolving_prefixes(c, profile.commands))
                  for c in profile.commands)
    return Grammar(profile, rules, tuple(profile.set_keywords))
