"""The one line a failed compile or link of a firmware tree is told in: the compiler's or linker's
own cause, with the tree's file names and lines, never only ``collect2: error: ld returned 1``.

A pico-sdk function or header the stand-in (``standin/``) does not provide is named with the file
and line that uses it: from the linker's ``undefined reference`` lines (a compiler that only warns
of an undeclared function, the firmware's files being compiled with ``-w``), or from the compiler's
own error where it refuses an undeclared function (GCC 14, clang 16) or a missing header.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Dict, List, Optional, Sequence

__all__ = ["link_failure", "compile_failure", "defined_in"]

# GNU ld, with the objects' line tables (-g): FILE:LINE: ..., or OBJECT:(.text+0x12): ... without.
_WHERE = r"(?P<where>\S+?):(?:(?P<line>\d+)|\([^)]*\))"
_QUOTED = r"[`'‘\"](?P<sym>[^'’`\"]+)['’`\"]"
_MULTIPLE = re.compile(_WHERE + r": multiple definition of " + _QUOTED
                       + r"; (?P<first>\S+?):(?:(?P<fline>\d+)|\([^)]*\)): first defined here")
_UNDEFINED = re.compile(_WHERE + r": undefined reference to " + _QUOTED)
_UNDECLARED = re.compile(r"(?P<where>[^\s:]+):(?P<line>\d+):\d+: error: (?:implicit declaration of function|"
                         r"call to undeclared function) " + _QUOTED)
_NO_HEADER = re.compile(r"(?P<where>[^\s:]+):(?P<line>\d+):\d+: fatal error: [`'‘\"]?(?P<header>[^'’`\":]+)"
                        r"['’`\"]?(?:: No such file or directory| file not found)")


def defined_in(name: str, files: Sequence[Path]) -> List[Path]:
    """The files among ``files`` that define the function ``name`` (a body, not a declaration)."""
    # its type before it on the same line or the line above (GNU style), its body after ")"
    pattern = re.compile(r"^(?:[A-Za-z_][\w \t\*]*[\s\*])?" + re.escape(name) + r"[ \t]*\([^;{]*\)\s*\{",
                         re.MULTILINE)
    return [p for p in files if pattern.search(p.read_text(encoding="utf-8", errors="replace"))]


def _name(where: str, objects: Dict[str, str]) -> str:
    """A tree file's name for a path or an object file the tool printed."""
    base = Path(where.split(":")[-1]).name      # OBJECT:SOURCE names the source
    return objects.get(base, base)


def _at(name: str, line: Optional[str]) -> str:
    return f"{name}:{line}" if line else name


def _missing(sym: str, caller: str, tree_files: Sequence[Path], left_out: Sequence[Path],
             origin: str, call_line: str) -> str:
    call = f"{sym}()" if re.search(re.escape(sym) + r"\s*\(", call_line) or not call_line else sym
    elsewhere = defined_in(sym, left_out)
    if elsewhere:
        return (f"`{call}`, called in {caller}, is defined in {elsewhere[0].name}, which {origin} "
                "leaves out")
    if defined_in(sym, tree_files):
        return f"undefined reference to `{call}`, called in {caller}"
    return f"the stand-in does not model `{call}`, called in {caller}"


def _source_line(tree: Path, name: str, line: Optional[str]) -> str:
    try:
        lines = (tree / name).read_text(encoding="utf-8", errors="replace").splitlines()
        return lines[int(line) - 1] if line else ""
    except (OSError, ValueError, IndexError):
        return ""


def link_failure(stderr: str, tree: Path, objects: Dict[str, str], sources: Sequence[Path],
                 left_out: Sequence[Path], origin: str) -> str:
    """The linker's cause in one line. ``objects``: object file name -> the tree file it was made from."""
    for m in _MULTIPLE.finditer(stderr):
        here = _at(_name(m.group("where"), objects), m.group("line"))
        first = _at(_name(m.group("first"), objects), m.group("fline"))
        return f"multiple definition of `{m.group('sym')}': {here} and {first}"
    for m in _UNDEFINED.finditer(stderr):
        name = _name(m.group("where"), objects)
        return _missing(m.group("sym"), _at(name, m.group("line")), sources, left_out, origin,
                        _source_line(tree, name, m.group("line")))
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    useful = [ln for ln in lines if not ln.startswith("collect2") and not ln.endswith("':")]
    chosen = useful[0] if useful else (lines[0] if lines else "the linker failed without a message")
    return re.sub(r"^\S*\bld(?:\.\w+)?: ", "", chosen)


def compile_failure(stderr: str, tree: Path, sources: Sequence[Path], left_out: Sequence[Path],
                    origin: str) -> Optional[str]:
    """The stand-in's gap a compile error shows (an undeclared pico-sdk function, a missing header),
    or None when the error is the tree's own."""
    m = _UNDECLARED.search(stderr)
    if m:
        name = Path(m.group("where")).name
        return _missing(m.group("sym"), f"{name}:{m.group('line')}", sources, left_out, origin,
                        _source_line(tree, name, m.group("line")))
    m = _NO_HEADER.search(stderr)
    if m:
        header, at = m.group("header"), f"{Path(m.group('where')).name}:{m.group('line')}"
        elsewhere = sorted(p for p in tree.rglob(Path(header).name) if p.is_file() and p.parent != tree)
        if elsewhere:
            folder = elsewhere[0].parent.relative_to(tree)
            return f"`{header}`, included in {at}, is in {folder}/ of the tree, which no include folder names"
        if header.startswith(("pico/", "hardware/", "boards/")) or header == "pico.h":
            return f"the stand-in has no `{header}`, included in {at}"
    return None
