"""Fuzz input from the grammar (fuzz/inputs/grammar.py), drawn with a seeded ``random.Random``.

Every input is a :class:`FuzzInput`: the exact bytes to send (always ending in CR, so whatever
follows starts on a fresh line) plus the productions it exercised, for coverage.

Why not Hypothesis strategies: profiled, drawing through Hypothesis cost about 80 % of a campaign
(~10 ms an input: every primitive draw is recorded for shrinking). Here an input costs tens of
microseconds, a run is a pure function of its seed (so nothing the target answers can change
what is drawn), and a finding is shrunk by replaying reduced scripts (fuzz/findings/shrink.py), which
works on every target, real ones included.

Families (docs/FIRMWARE-BEHAVIOUR.md#fb-line, #fb-matching, #fb-arguments, for why each is
interesting):
- ``valid``: one command in any resolving abbreviation, arguments at and past their clamp
  boundaries, both separators after the name;
- ``multi``: several commands on one line with ``;``/space runs between them (no ``;`` needed);
- ``near``: a valid line with one token mutated (wrong type, missing/extra argument, exponent,
  huge number, en dash, case, double sign, ``0x``, over-long name, another release's command);
- ``bytes``: byte-level damage (LF, TAB, NUL, BS/DEL, ``#``, lines over 256 bytes, bytes >= 0x80);
- ``noise``: raw bytes.
"""
from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Callable, Dict, List, Tuple

from .grammar import FORMATS, Arg, Form, Grammar, Repeat, resolving_prefixes

__all__ = ["FuzzInput", "InputGenerator", "FAMILIES", "check_families"]

FAMILIES = ("valid", "multi", "near", "bytes", "noise")
SEPARATORS = (" ", ";", " ; ", ";;", "  ", "; ", " ;")


@dataclass(frozen=True)
class FuzzInput:
    data: bytes
    family: str
    productions: Tuple[str, ...] = ()

    def __str__(self) -> str:
        return f"{self.family}:{self.data!r}"


# ``random.Random.choice``/``randint`` go through ``_randbelow`` (a loop of getrandbits): a third
# of the generator's time. One float draw scaled is as uniform as a test input needs.
def _pick(rng: random.Random, seq):  # type: ignore[no-untyped-def]
    return seq[int(rng.random() * len(seq))]


def _below(rng: random.Random, n: int) -> int:
    return int(rng.random() * n)


def _between(rng: random.Random, lo: int, hi: int) -> int:
    return lo + int(rng.random() * (hi - lo + 1))


def check_families(families: Tuple[str, ...]) -> None:
    unknown = set(families) - set(FAMILIES)
    if unknown or not families:
        raise ValueError(f"unknown input families {sorted(unknown)} (known: {', '.join(FAMILIES)})")


_WRAPS = (2**31 - 1, 2**31, 2**32 - 1, 2**32, 2**32 + 1, 10**12)
_SIGNS = ("", "", "-", "+")
_SHAPES = ("d", "d.d", ".d", "d.", "long", "boundary")
_LONG = ("0.0027777778", "123456789012", "1234567890.5", "0.000000000001", "99999999999999999999",
         "3.14159265358979")
_HEX_ODD = ("123", "fff", "FFFFFFFF", "100000000", "0")
_AFTER_NAME = (" ", " ", ";", "  ")            # `set;0.25` = `set 0.25` (fb-matching)
_BETWEEN_ARGS = (" ", " ", "  ")
_WRONG = ("x", "abc", "1.5", "ff", "0x12", "u1", "-", "+", ".", "-.", "", "1e3", "2E-2", "1e", "+-1",
          "- 1", "--1", "\u20131", "\u2013", "99999999999999999999", "4294967296", "-2147483649",
          "1,5", "0b1", "NaN", "inf")
_NEAR_HOW = ("wrong", "drop", "extra", "case", "long_name", "other_release", "en_dash", "leading_space_hash")
_INSERTS = (b"\n", b"\t", b"\x00", b"\x08", b"\x7f", b"#", b"\xff", b"\x80", "\u00e9".encode(),
            "\u2013".encode(), b"\x1b", b"\x02", b"\x03")
_NOT_CR = bytes(b for b in range(256) if b != 0x0D)
_BYTES_HOW = ("insert", "replace", "prefix_hash", "overlong", "edit", "lf_prefix")


def _int_boundaries(arg: Arg) -> Tuple[int, ...]:
    vals = [0, 1]
    if arg.lo is not None:
        vals += [int(arg.lo), int(arg.lo) - 1]
    if arg.hi is not None:
        vals += [int(arg.hi), int(arg.hi) + 1]
    return tuple(vals)


def _float_bounds(arg: Arg) -> Tuple[str, ...]:
    bounds = ["0", "-0", "1", "0.5", "0.02", "0.019", "1.0000001", "0.9999999"]
    for v in (arg.lo, arg.hi):
        if v is not None:
            bounds += [f"{v:f}".rstrip("0").rstrip("."), f"{v - 0.001:f}", f"{v + 0.001:f}"]
    return tuple(sorted(set(bounds)))


class InputGenerator:
    """Inputs of the given families for one grammar; ``rng`` is the only source of chance."""

    def __init__(self, grammar: Grammar, families: Tuple[str, ...] = FAMILIES):
        check_families(families)
        self.grammar = grammar
        # ``valid`` and ``near`` weigh double, so most lines reach deep into commands.
        self._families = tuple(f for f in families for _ in range(2 if f in ("valid", "near") else 1))
        self._makers: Dict[str, Callable[[random.Random], FuzzInput]] = {
            "valid": self.valid, "multi": self.multi, "near": self.near, "bytes": self.bytes,
            "noise": self.noise}
        self._prefixes = {kw: tuple(resolving_prefixes(kw, grammar.set_keywords))
                          for form in (f for r in grammar.commands for f in r.forms)
                          for kw in form.items if isinstance(kw, str)}
        self._bounds: Dict[Arg, tuple] = {}

    def input(self, rng: random.Random) -> FuzzInput:
        return self._makers[_pick(rng, self._families)](rng)

    # -- arguments ---------------------------------------------------------------------------
    def _digits(self, rng: random.Random) -> str:
        return "".join(_pick(rng, "0123456789") for _ in range(_between(rng, 1, 4)))

    def _float(self, rng: random.Random, arg: Arg) -> str:
        sign, shape = _pick(rng, _SIGNS), _pick(rng, _SHAPES)
        if shape == "d":
            return sign + self._digits(rng)
        if shape == "d.d":
            return sign + self._digits(rng) + "." + self._digits(rng)
        if shape == ".d":
            return sign + "." + self._digits(rng)
        if shape == "d.":
            return sign + self._digits(rng) + "."
        if shape == "long":        # beyond the 9-digit accumulator (fb-numbers)
            return sign + _pick(rng, _LONG)
        bounds = self._bounds.get(arg)
        if bounds is None:
            bounds = self._bounds[arg] = _float_bounds(arg)
        return _pick(rng, bounds)

    def arg_text(self, rng: random.Random, arg: Arg) -> str:
        """Text for one argument: in range, at the clamp boundaries and just past them."""
        if arg.kind == "format":
            return _pick(rng, FORMATS)
        if arg.kind == "hex":
            how = _below(rng, 3)
            if how == 2:
                return _pick(rng, _HEX_ODD)
            return f"{_between(rng, 0, 255):{'x' if how == 0 else '02X'}}"
        if arg.kind == "float":
            return self._float(rng, arg)
        lo = int(arg.lo) if arg.lo is not None else 0
        hi = int(arg.hi) if arg.hi is not None else 100
        how = _below(rng, 3)
        v = _between(rng, lo, hi) if how == 0 else _pick(rng, _int_boundaries(arg) if how == 1 else _WRAPS)
        if arg.kind == "unsigned":
            return str(abs(v))
        return str(v) if v < 0 else _pick(rng, ("", "", "+")) + str(v)

    def _form_args(self, rng: random.Random, form: Form) -> List[str]:
        toks: List[str] = []
        for item in form.items:
            if isinstance(item, str):     # a keyword, in any abbreviation that still resolves to it
                toks.append(_pick(rng, self._prefixes[item]))
            elif isinstance(item, Arg):
                toks.append(self.arg_text(rng, item))
            elif isinstance(item, Repeat):
                for _ in range(_between(rng, 0, min(item.max + 1, 17))):   # one more than the firmware reads
                    toks.extend(self.arg_text(rng, a) for a in item.group)
        return toks

    def command_tokens(self, rng: random.Random) -> Tuple[str, List[str], str]:
        """(command word as typed, argument tokens, production)."""
        rule = _pick(rng, self.grammar.commands)
        form = _pick(rng, rule.forms)
        return _pick(rng, rule.prefixes), self._form_args(rng, form), form.production

    @staticmethod
    def _join(rng: random.Random, word: str, args: List[str]) -> str:
        if not args:
            return word
        rest = "".join(_pick(rng, _BETWEEN_ARGS) + a for a in args[1:])
        return word + _pick(rng, _AFTER_NAME) + args[0] + rest

    # -- families ----------------------------------------------------------------------------
    def valid(self, rng: random.Random) -> FuzzInput:
        word, args, prod = self.command_tokens(rng)
        return FuzzInput((self._join(rng, word, args) + "\r").encode(), "valid", (prod,))

    def multi(self, rng: random.Random) -> FuzzInput:
        parts, prods = [], []
        for _ in range(_between(rng, 2, 4)):
            word, args, prod = self.command_tokens(rng)
            parts.append(self._join(rng, word, args))
            prods.append(prod)
        text = parts[0] + "".join(_pick(rng, SEPARATORS) + p for p in parts[1:])
        if rng.random() < 0.5:
            text = _pick(rng, ("", ";", " ", " ;")) + text + _pick(rng, ("", ";", " "))
        return FuzzInput((text + "\r").encode(), "multi", tuple(prods))

    def near(self, rng: random.Random) -> FuzzInput:
        word, args, prod = self.command_tokens(rng)
        how = _pick(rng, _NEAR_HOW)
        if how == "wrong" and args:
            args[_below(rng, len(args))] = _pick(rng, _WRONG)
        elif how == "drop" and args:
            del args[_below(rng, len(args))]
        elif how == "extra":
            args.insert(_between(rng, 0, len(args)), _pick(rng, ("7", "x", "0", "1.5", "ff")))
        elif how == "case":
            word = _pick(rng, (word.upper(), word.capitalize(), word.swapcase()))
        elif how == "long_name":
            word = word + _pick(rng, ("x", "s", "_", "1"))
        elif how == "other_release" and self.grammar.unknown_words:
            word = _pick(rng, self.grammar.unknown_words)
        elif how == "en_dash":
            args = [a.replace("-", "\u2013") for a in args] or ["\u20131"]
        elif how == "leading_space_hash":
            word = " #" + word
        return FuzzInput((self._join(rng, word, args) + "\r").encode("utf-8"), "near", (prod, "near." + how))

    def bytes(self, rng: random.Random) -> FuzzInput:
        base = self.valid(rng) if rng.random() < 0.5 else self.multi(rng)
        body = bytearray(base.data[:-1])
        how = _pick(rng, _BYTES_HOW)
        if how == "insert":
            i = _between(rng, 0, len(body))
            body[i:i] = _pick(rng, _INSERTS)
        elif how == "replace" and body:
            i = _below(rng, len(body))
            body[i:i + 1] = _pick(rng, _INSERTS)
        elif how == "prefix_hash":
            body[0:0] = b"#"
        elif how == "overlong":       # the 256-byte buffer: the tail is cut (fb-line-buffer)
            pad = max(_between(rng, 240, 300) - len(body), 0) * _pick(rng, (b" ", b";", b"x", b"0"))
            body = (pad + body) if rng.random() < 0.5 else (body + pad)
        elif how == "edit":           # type a wrong character and take it back (BS or DEL)
            i = _between(rng, 0, len(body))
            junk = bytes(_pick(rng, _NOT_CR) for _ in range(_between(rng, 1, 3)))
            rub = _pick(rng, (b"\x08", b"\x7f")) * _between(rng, len(junk), len(junk) + 2)
            body[i:i] = junk + rub
        elif how == "lf_prefix":      # a host that ends lines with CRLF (fb-control-bytes)
            body[0:0] = b"\n"
        return FuzzInput(bytes(body) + b"\r", "bytes", base.productions + ("bytes." + how,))

    def noise(self, rng: random.Random) -> FuzzInput:
        data = rng.randbytes(_between(rng, 0, 300))
        return FuzzInput(data + b"\r", "noise", ("noise",))
