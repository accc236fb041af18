"""Hypothesis strategies generated from the grammar (fuzz/grammar.py).

Every strategy yields a :class:`FuzzInput`: the exact bytes to send (always ending in CR, so the
fence that follows starts on a fresh line) plus the productions it exercised, for coverage.

Families (the brief's list, FIRMWARE-FACTS §1-§3 for why each is interesting):
- ``valid``: one command in any resolving abbreviation, arguments at and past their clamp
  boundaries, both separators after the name;
- ``multi``: several commands on one line with ``;``/space runs between them (no ``;`` needed);
- ``near``: a valid line with one token mutated (wrong type, missing/extra argument, exponent,
  huge number, en dash, case, double sign, ``0x``, over-long name, another release's command);
- ``bytes``: byte-level damage (LF, TAB, NUL, BS/DEL, ``#``, lines over 256 bytes, bytes >= 0x80);
- ``noise``: raw bytes.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Tuple

from hypothesis import strategies as st

from .grammar import FORMATS, Arg, Form, Grammar, Repeat, resolving_prefixes

__all__ = ["FuzzInput", "arg_text", "command_tokens", "valid_command", "multi_command", "near_valid",
           "byte_mutation", "raw_noise", "fuzz_input", "FAMILIES"]

FAMILIES = ("valid", "multi", "near", "bytes", "noise")
SEPARATORS = (" ", ";", " ; ", ";;", "  ", "; ", " ;")


@dataclass(frozen=True)
class FuzzInput:
    data: bytes
    family: str
    productions: Tuple[str, ...] = ()

    def __str__(self) -> str:
        return f"{self.family}:{self.data!r}"


# -- numbers --------------------------------------------------------------------------------
_WRAPS = (2**31 - 1, 2**31, 2**32 - 1, 2**32, 2**32 + 1, 10**12)


def _int_boundaries(arg: Arg) -> List[int]:
    vals = [0, 1]
    if arg.lo is not None:
        vals += [int(arg.lo), int(arg.lo) - 1]
    if arg.hi is not None:
        vals += [int(arg.hi), int(arg.hi) + 1]
    return vals


_SIGNS = st.sampled_from(["", "", "-", "+"])
_SHAPES = st.sampled_from(["d", "d.d", ".d", "d.", "long", "boundary"])
_DIGITS = st.text("0123456789", min_size=1, max_size=4)
_LONG = st.sampled_from(["0.0027777778", "123456789012", "1234567890.5", "0.000000000001",
                         "99999999999999999999", "3.14159265358979"])


_BOUNDS_CACHE: dict = {}


def _float_bounds(arg: Arg) -> st.SearchStrategy[str]:
    if arg in _BOUNDS_CACHE:
        return _BOUNDS_CACHE[arg]
    bounds = ["0", "-0", "1", "0.5", "0.02", "0.019", "1.0000001", "0.9999999"]
    for v in (arg.lo, arg.hi):
        if v is not None:
            bounds += [f"{v:f}".rstrip("0").rstrip("."), f"{v - 0.001:f}", f"{v + 0.001:f}"]
    _BOUNDS_CACHE[arg] = st.sampled_from(sorted(set(bounds)))
    return _BOUNDS_CACHE[arg]


@st.composite
def _float_text(draw, arg: Arg) -> str:
    sign = draw(_SIGNS)
    shape = draw(_SHAPES)
    digits = _DIGITS
    if shape == "d":
        return sign + draw(digits)
    if shape == "d.d":
        return sign + draw(digits) + "." + draw(digits)
    if shape == ".d":
        return sign + "." + draw(digits)
    if shape == "d.":
        return sign + draw(digits) + "."
    if shape == "long":        # beyond the 9-digit accumulator (§3)
        return sign + draw(_LONG)
    return draw(_float_bounds(arg))


_ARG_CACHE: dict = {}


def arg_text(arg: Arg) -> st.SearchStrategy[str]:
    """Text for one argument (cached per argument: building strategies is not free)."""
    if arg not in _ARG_CACHE:
        _ARG_CACHE[arg] = _arg_text(arg)
    return _ARG_CACHE[arg]


def _arg_text(arg: Arg) -> st.SearchStrategy[str]:
    """Text for one argument: in range, at the clamp boundaries and just past them."""
    if arg.kind == "format":
        return st.sampled_from(FORMATS)
    if arg.kind == "hex":
        return st.one_of(st.integers(0, 255).map(lambda v: f"{v:x}"),
                         st.integers(0, 255).map(lambda v: f"{v:02X}"),
                         st.sampled_from(["123", "fff", "FFFFFFFF", "100000000", "0"]))
    if arg.kind == "float":
        return _float_text(arg)
    lo = int(arg.lo) if arg.lo is not None else 0
    hi = int(arg.hi) if arg.hi is not None else 100
    ints = st.one_of(st.integers(lo, hi), st.sampled_from(_int_boundaries(arg)),
                     st.sampled_from(_WRAPS))
    if arg.kind == "unsigned":
        return ints.map(lambda v: str(abs(v)))
    return st.tuples(ints, st.sampled_from(["", "", "+"])).map(
        lambda t: (t[1] + str(t[0])) if t[0] >= 0 else str(t[0]))


@st.composite
def _form_args(draw, form: Form, keywords: Tuple[str, ...]) -> List[str]:
    toks: List[str] = []
    for item in form.items:
        if isinstance(item, str):     # a keyword, in any abbreviation that still resolves to it
            toks.append(draw(st.sampled_from(resolving_prefixes(item, keywords))))
        elif isinstance(item, Arg):
            toks.append(draw(arg_text(item)))
        elif isinstance(item, Repeat):
            n = draw(st.integers(0, min(item.max + 1, 17)))   # one more than the firmware reads
            for _ in range(n):
                toks.extend(draw(arg_text(a)) for a in item.group)
    return toks


@st.composite
def command_tokens(draw, grammar: Grammar) -> Tuple[str, List[str], str]:
    """(command word as typed, argument tokens, production)."""
    rule = draw(st.sampled_from(grammar.commands))
    form = draw(st.sampled_from(rule.forms))
    word = draw(st.sampled_from(rule.prefixes))
    return word, draw(_form_args(form, grammar.set_keywords)), form.production


_AFTER_NAME = st.sampled_from([" ", " ", ";", "  "])
_BETWEEN_ARGS = st.sampled_from([" ", " ", "  "])
_SEPARATORS = st.sampled_from(SEPARATORS)


@st.composite
def _join(draw, word: str, args: List[str]) -> str:
    if not args:
        return word
    first = draw(_AFTER_NAME)   # `set;0.25` = `set 0.25` (§2)
    rest = "".join(draw(_BETWEEN_ARGS) + a for a in args[1:])
    return word + first + args[0] + rest


@st.composite
def valid_command(draw, grammar: Grammar) -> FuzzInput:
    word, args, prod = draw(command_tokens(grammar))
    return FuzzInput((draw(_join(word, args)) + "\r").encode(), "valid", (prod,))


@st.composite
def multi_command(draw, grammar: Grammar) -> FuzzInput:
    parts, prods = [], []
    for _ in range(draw(st.integers(2, 4))):
        word, args, prod = draw(command_tokens(grammar))
        parts.append(draw(_join(word, args)))
        prods.append(prod)
    text = parts[0]
    for p in parts[1:]:
        text += draw(_SEPARATORS) + p
    if draw(st.booleans()):
        text = draw(st.sampled_from(["", ";", " ", " ;"])) + text + draw(st.sampled_from(["", ";", " "]))
    return FuzzInput((text + "\r").encode(), "multi", tuple(prods))


# -- one-token mutations --------------------------------------------------------------------
_WRONG = ("x", "abc", "1.5", "ff", "0x12", "u1", "-", "+", ".", "-.", "", "1e3", "2E-2", "1e", "+-1",
          "- 1", "--1", "\u20131", "\u2013", "99999999999999999999", "4294967296", "-2147483649",
          "1,5", "0b1", "NaN", "inf")


@st.composite
def near_valid(draw, grammar: Grammar) -> FuzzInput:
    word, args, prod = draw(command_tokens(grammar))
    how = draw(st.sampled_from(["wrong", "drop", "extra", "case", "long_name", "other_release",
                                "en_dash", "leading_space_hash"]))
    if how == "wrong" and args:
        i = draw(st.integers(0, len(args) - 1))
        args[i] = draw(st.sampled_from(_WRONG))
    elif how == "drop" and args:
        del args[draw(st.integers(0, len(args) - 1))]
    elif how == "extra":
        args.insert(draw(st.integers(0, len(args))), draw(st.sampled_from(["7", "x", "0", "1.5", "ff"])))
    elif how == "case":
        word = draw(st.sampled_from([word.upper(), word.capitalize(), word.swapcase()]))
    elif how == "long_name":
        word = word + draw(st.sampled_from(["x", "s", "_", "1"]))
    elif how == "other_release" and grammar.unknown_words:
        word = draw(st.sampled_from(grammar.unknown_words))
    elif how == "en_dash":
        args = [a.replace("-", "\u2013") for a in args] or ["\u20131"]
    elif how == "leading_space_hash":
        word = " #" + word
    text = draw(_join(word, args))
    return FuzzInput((text + "\r").encode("utf-8"), "near", (prod, "near." + how))


# -- byte-level damage ----------------------------------------------------------------------
_INSERTS = (b"\n", b"\t", b"\x00", b"\x08", b"\x7f", b"#", b"\xff", b"\x80", "\u00e9".encode(),
            "\u2013".encode(), b"\x1b", b"\x02", b"\x03")


@st.composite
def byte_mutation(draw, grammar: Grammar) -> FuzzInput:
    base = draw(st.one_of(valid_command(grammar), multi_command(grammar)))
    body = bytearray(base.data[:-1])
    how = draw(st.sampled_from(["insert", "replace", "prefix_hash", "overlong", "edit", "lf_prefix"]))
    if how == "insert":
        body[draw(st.integers(0, len(body))):0] = draw(st.sampled_from(_INSERTS))
    elif how == "replace" and body:
        i = draw(st.integers(0, len(body) - 1))
        body[i:i + 1] = draw(st.sampled_from(_INSERTS))
    elif how == "prefix_hash":
        body[0:0] = b"#"
    elif how == "overlong":       # the 256-byte buffer: the tail is cut (§1)
        pad = draw(st.integers(240, 300)) - len(body)
        filler = draw(st.sampled_from([b" ", b";", b"x", b"0"]))
        where = draw(st.sampled_from(["before", "after"]))
        body = (filler * max(pad, 0) + body) if where == "before" else (body + filler * max(pad, 0))
    elif how == "edit":           # type a wrong character and take it back (BS or DEL)
        i = draw(st.integers(0, len(body)))
        junk = draw(st.binary(min_size=1, max_size=3).filter(lambda b: b"\r" not in b))
        rub = draw(st.sampled_from([b"\x08", b"\x7f"])) * draw(st.integers(len(junk), len(junk) + 2))
        body[i:i] = junk + rub
    elif how == "lf_prefix":      # a host that ends lines with CRLF (§1)
        body[0:0] = b"\n"
    return FuzzInput(bytes(body) + b"\r", "bytes", base.productions + ("bytes." + how,))


@st.composite
def raw_noise(draw, grammar: Grammar) -> FuzzInput:
    data = draw(st.binary(min_size=0, max_size=300))
    return FuzzInput(data + b"\r", "noise", ("noise",))


_FAMILY_STRATEGIES = {"valid": valid_command, "multi": multi_command, "near": near_valid,
                      "bytes": byte_mutation, "noise": raw_noise}


def fuzz_input(grammar: Grammar, families: Tuple[str, ...] = FAMILIES) -> st.SearchStrategy[FuzzInput]:
    """Any family; ``valid`` and ``near`` are listed twice so most lines reach deep into commands."""
    unknown = set(families) - set(FAMILIES)
    if unknown:
        raise ValueError(f"unknown input families {sorted(unknown)} (known: {', '.join(FAMILIES)})")
    weighted = [f for f in families for _ in range(2 if f in ("valid", "near") else 1)]
    return st.one_of(*[_FAMILY_STRATEGIES[f](grammar) for f in weighted])
