"""Single-site mutants of a firmware tree's C code: the planted regressions `sil mutate` runs.

Each :class:`Mutant` changes one place of one C file: a relational or logical operator, an
arithmetic operator, a small integer constant, one character of a string literal (what a
reply prints), or a whole call statement deleted. Sites are found by a small lexer of our own
(comments, preprocessor lines, and for operators string and character literals, are skipped);
:func:`sample` draws a seeded selection across the chosen files. Nothing is written to the
tree: :meth:`Mutant.apply` returns the changed text of the file.
"""
from __future__ import annotations

import hashlib
import random
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Iterator, List, Optional, Sequence

__all__ = ["Mutant", "find_mutants", "sample", "KINDS", "DEFAULT_FILES"]

KINDS = ("relational", "logical", "arithmetic", "constant", "string", "call")
# The firmware's command, number-formatting, device, message, controller and port files.
DEFAULT_FILES = ("command.c", "ioconv.c", "device.c", "message.c", "control.c", "pwm_pid.c", "ports.c",
                 "main.c")

_RELATIONAL = {"<": "<=", "<=": "<", ">": ">=", ">=": ">", "==": "!=", "!=": "=="}
_LOGICAL = {"&&": "||", "||": "&&"}
_ARITHMETIC = {"+": "-", "-": "+", "*": "/", "/": "*"}
_TOKEN = re.compile(r"""
    (?P<comment>//[^\n]*|/\*.*?\*/)
  | (?P<string>"(?:\\.|[^"\\\n])*")
  | (?P<char>'(?:\\.|[^'\\\n])+')
  | (?P<number>\b(?:0[xX][0-9A-Fa-f]+|\d+)[uUlL]*\b(?!\.))
  | (?P<ident>[A-Za-z_]\w*)
  | (?P<op><<=|>>=|<<|>>|<=|>=|==|!=|&&|\|\||\+\+|--|->|[-+*/%<>=!&|^~?:;,.(){}\[\]])
  | (?P<space>\s+)
  | (?P<other>.)
""", re.S | re.X)
_CALL_STATEMENT = re.compile(r"^(\s*)([A-Za-z_]\w*)\s*\([^;{}]*\)\s*;\s*(//.*)?$")
_NOT_CALLS = {"if", "while", "for", "switch", "return", "sizeof", "case", "else", "do", "goto", "break"}


@dataclass(frozen=True)
class Mutant:
    file: str          # file name in the tree
    line: int          # 1-based
    offset: int        # character offset in the file
    kind: str
    original: str
    replacement: str
    function: str = ""  # the enclosing function, for the report

    @property
    def ident(self) -> str:
        """A name of its own (a campaign's folder for it): sampling draws one mutant per site and
        kind, but two plants can change the same place differently, so a plant's name also
        carries a digest of its change."""
        site = f"{Path(self.file).stem}-{self.line}-{self.kind}-{self.offset}"
        if self.kind != "planted":
            return site
        change = (self.original + "\0" + self.replacement).encode("utf-8")
        return f"{site}-{hashlib.sha1(change).hexdigest()[:8]}"

    def apply(self, text: str) -> str:
        if text[self.offset:self.offset + len(self.original)] != self.original:
            raise ValueError(f"{self.file}:{self.line}: the tree changed since the mutant was made")
        return text[:self.offset] + self.replacement + text[self.offset + len(self.original):]

    def describe(self) -> str:
        return f"{self.file}:{self.line} ({self.kind}) {self.original!r} -> {self.replacement!r}"


def _line_of(text: str, offset: int) -> int:
    return text.count("\n", 0, offset) + 1


def _functions(text: str) -> List[tuple]:
    """(offset, name) of each function definition, in order (a name, '(', ... ')' then '{')."""
    out = []
    for m in re.finditer(r"^[A-Za-z_][\w \t\*]*?\b([A-Za-z_]\w*)\s*\([^;{}]*\)\s*\{", text, re.M):
        if m.group(1) not in _NOT_CALLS:
            out.append((m.start(), m.group(1)))
    return out


def _function_at(funcs: List[tuple], offset: int) -> str:
    name = ""
    for start, fn in funcs:
        if start > offset:
            break
        name = fn
    return name


def _preprocessor_spans(text: str) -> List[tuple]:
    return [(m.start(), m.end()) for m in re.finditer(r"^[ \t]*#[^\n]*(?:\\\n[^\n]*)*", text, re.M)]


_TYPE_WORDS = {"int", "char", "float", "double", "void", "unsigned", "signed", "short", "long", "const",
               "volatile", "bool", "uint", "size_t", "uint8_t", "uint16_t", "uint32_t", "uint64_t", "int8_t",
               "int16_t", "int32_t", "int64_t"}


def _type_names(text: str) -> set:
    """Words that name a type here: C's, the tree's typedefs, and every struct tag."""
    names = set(_TYPE_WORDS)
    names.update(re.findall(r"typedef[^;{]*?\b(\w+)\s*;", text))
    names.update(re.findall(r"\bstruct\s+(\w+)", text))
    return names


def _sites(name: str, text: str, types: set) -> Iterator[Mutant]:
    funcs = _functions(text)
    pre = _preprocessor_spans(text)
    tokens = [(m.lastgroup, m.group(), m.start()) for m in _TOKEN.finditer(text)]
    code = [t for t in tokens if t[0] not in ("space", "comment")]

    def in_pre(off: int) -> bool:
        return any(a <= off < b for a, b in pre)

    def mutant(kind: str, off: int, old: str, new: str) -> Mutant:
        return Mutant(name, _line_of(text, off), off, kind, old, new, _function_at(funcs, off))

    for i, (kind, tok, off) in enumerate(code):
        if in_pre(off) or not _function_at(funcs, off):
            continue           # declarations and tables outside functions stay as they are
        prev = code[i - 1] if i else ("", "", 0)
        before = code[i - 2] if i > 1 else ("", "", 0)
        binary = prev[0] in ("ident", "number", "string", "char") or prev[1] in (")", "]")
        if tok == "*" and (prev[1] in types or before[1] == "struct"):
            binary = False     # a pointer declaration or cast, not a product
        if kind == "op" and tok in _RELATIONAL and binary:
            yield mutant("relational", off, tok, _RELATIONAL[tok])
        elif kind == "op" and tok in _LOGICAL:
            yield mutant("logical", off, tok, _LOGICAL[tok])
        elif kind == "op" and tok in _ARITHMETIC and binary:
            yield mutant("arithmetic", off, tok, _ARITHMETIC[tok])
        elif kind == "number" and re.fullmatch(r"\d+[uUlL]*", tok) and int(tok.rstrip("uUlL")) < 256:
            value = int(tok.rstrip("uUlL"))
            yield mutant("constant", off, tok, str(value + 1) if value in (0, 1) else str(value - 1))
        elif kind == "string" and len(tok) > 2:
            body = tok[1:-1]
            for j, ch in enumerate(body):
                if ch.isalpha() and (j == 0 or body[j - 1] != "\\"):
                    new = ch.lower() if ch.isupper() else ch.upper()
                    yield mutant("string", off + 1 + j, ch, new)
                    break
    offset = 0
    for line in text.splitlines(keepends=True):
        m = _CALL_STATEMENT.match(line.rstrip("\n"))
        if m and m.group(2) not in _NOT_CALLS and _function_at(funcs, offset) and not in_pre(offset):
            start = offset + len(m.group(1))
            stmt = line.rstrip("\n")[len(m.group(1)):]
            if m.group(3):
                stmt = stmt[:stmt.index("//")].rstrip()
            yield mutant("call", start, stmt, ";")
        offset += len(line)


def find_mutants(tree: Path, files: Sequence[str] = DEFAULT_FILES,
                 kinds: Sequence[str] = KINDS) -> List[Mutant]:
    """Every mutation site of ``files`` (names in the tree; missing ones are skipped)."""
    types: set = set()
    for header in sorted(Path(tree).glob("*.[ch]")):
        types |= _type_names(header.read_text(encoding="utf-8", errors="replace"))
    out: List[Mutant] = []
    for name in files:
        path = Path(tree) / name
        if not path.is_file():
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        out.extend(m for m in _sites(name, text, types) if m.kind in kinds)
    return out


def sample(mutants: Sequence[Mutant], count: int, seed: int) -> List[Mutant]:
    """``count`` mutants, drawn with ``seed`` so that every file and kind gets its share:
    round-robin over (file, kind) groups in a seeded order."""
    rng = random.Random(seed)
    groups: Dict[tuple, List[Mutant]] = {}
    for m in mutants:
        groups.setdefault((m.file, m.kind), []).append(m)
    for g in groups.values():
        rng.shuffle(g)
    keys = sorted(groups)
    rng.shuffle(keys)
    chosen: List[Mutant] = []
    while len(chosen) < count and any(groups.values()):
        for k in keys:
            if groups[k] and len(chosen) < count:
                chosen.append(groups[k].pop())
    return sorted(chosen, key=lambda m: (m.file, m.offset))


def planted(tree: Path, file: str, original: str, replacement: str) -> Optional[Mutant]:
    """A mutant given by hand (a test's planted regression): the first place ``original`` stands."""
    text = (Path(tree) / file).read_text(encoding="utf-8", errors="replace")
    off = text.find(original)
    if off < 0:
        return None
    return Mutant(file, _line_of(text, off), off, "planted", original, replacement,
                  _function_at(_functions(text), off))
