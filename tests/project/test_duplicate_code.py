"""No copied code inside the package (the tests aside): a run of WINDOW tokens of the same shape
in two places is one piece of logic written twice, and should be one function both places call.

Tokens, not lines: comments, docstrings, import statements and layout do not count; names count
as one (a copy with its variables renamed is still a copy), keywords, operators and values as
themselves. The only pairs allowed are the deliberate ones below, each with its reason.
"""
from __future__ import annotations

import io
import keyword
import tokenize
from typing import Dict, List, Set, Tuple

from repo_paths import REPO

TOPS = ("protocol", "harness", "transcripts", "emulator", "sil", "fuzz", "conformance", "bench",
        "buildhat_conformance")
WINDOW = 70          # about seven dense lines
# (file, file): written twice on purpose.
INDEPENDENT = {
    # The suite computes its expectations with its own oracles, never the emulator's code
    # (docs/DEVELOPING.md, "Honesty"): the float printer is the firmware's rule written twice.
    ("conformance/oracles/floatfmt.py", "emulator/commands/printers.py"),
}
SKIP = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT,
        tokenize.ENCODING, tokenize.ENDMARKER}


def tokens(source: str) -> List[Tuple[str, int]]:
    """(token text, line) of the code that counts: no comments, docstrings or import statements."""
    out: List[Tuple[str, int]] = []
    line_start = True            # at the start of a logical line
    skipping = False             # inside an import statement or a lone string (a docstring)
    toks = list(tokenize.generate_tokens(io.StringIO(source).readline))
    for i, tok in enumerate(toks):
        if tok.type == tokenize.NEWLINE:
            line_start, skipping = True, False
            continue
        if tok.type in SKIP:
            continue
        if line_start:
            line_start = False
            nxt = toks[i + 1] if i + 1 < len(toks) else None
            skipping = tok.string in ("import", "from") or (
                tok.type == tokenize.STRING and nxt is not None and nxt.type == tokenize.NEWLINE)
        if not skipping:
            name = tok.type == tokenize.NAME and not keyword.iskeyword(tok.string)
            out.append(("N" if name else tok.string, tok.start[0]))
    return out


def copies(files: Dict[str, str], window: int = WINDOW) -> Dict[Tuple[str, str], Tuple[int, int]]:
    """(file, file) -> (line, line) of the first window of tokens they share; a file against
    itself too (a run written twice in one module), at places that do not overlap."""
    seen: Dict[Tuple[str, ...], Tuple[str, int, int]] = {}
    found: Dict[Tuple[str, str], Tuple[int, int]] = {}
    for name in sorted(files):
        toks = tokens(files[name])
        texts = [t for t, _ in toks]
        for i in range(len(toks) - window + 1):
            key = tuple(texts[i:i + window])
            first = seen.get(key)
            if first is None:
                seen[key] = (name, i, toks[i][1])
                continue
            other, j, line = first
            if other == name and i - j < window:
                continue                     # the same run, overlapping itself (a long repeat)
            found.setdefault((other, name), (line, toks[i][1]))
    return found


def package_sources() -> Dict[str, str]:
    return {str(p.relative_to(REPO)): p.read_text(encoding="utf-8")
            for top in TOPS for p in sorted((REPO / top).rglob("*.py")) if "__pycache__" not in p.parts}


def test_the_check_finds_a_planted_copy():
    body = ("def f(a, b):\n    total = 0\n    for x in range(a):\n        if x % b == 0:\n"
            "            total += x * x - b\n        else:\n            total -= x + b\n    return total\n")
    other = "'''Another module.'''\nimport os  # imports do not count\n" + body.replace("def f", "def g")
    assert copies({"a.py": body, "b.py": other}, window=30) == {("a.py", "b.py"): (1, 3)}
    renamed = other.replace("total", "acc").replace("x", "item")
    assert copies({"a.py": body, "b.py": renamed}, window=30) == {("a.py", "b.py"): (1, 3)}
    assert copies({"a.py": body, "b.py": body.replace("x % b", "x % (b + 1)")}, window=40) == {}


def test_docstrings_comments_and_imports_are_not_code():
    src = '"""doc"""\nimport os\nfrom x import (a,\n    b)\nx = 1  # note\n'
    assert [t for t, _ in tokens(src)] == ["N", "=", "1"]


def test_no_code_is_written_twice_in_the_package():
    found = copies(package_sources())
    pairs = {tuple(sorted(pair)): lines for pair, lines in found.items()}
    unexplained = [f"{a}:{pairs[(a, b)][0]} ~ {b}:{pairs[(a, b)][1]}" for a, b in sorted(pairs)
                   if (a, b) not in INDEPENDENT]
    assert not unexplained, "the same code in two places:\n" + "\n".join(unexplained)


def test_every_deliberate_pair_is_still_there():
    # An exception nobody needs any more is an exception the next copy could hide behind.
    found: Set[Tuple[str, ...]] = {tuple(sorted(pair)) for pair in copies(package_sources())}
    assert INDEPENDENT <= found, INDEPENDENT - found
