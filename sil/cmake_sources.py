"""What a firmware tree's ``CMakeLists.txt`` says its executables are made of: their source files,
compile definitions and include folders. A reader of the file's text, not CMake: nothing is run.

It follows what CMake files of the firmware's years write: comments (``#`` and ``#[[ ]]``), one
argument per line or many, quoted and bracket arguments, ``set``/``list(APPEND)`` variables and
``${...}`` (nested), ``file(GLOB)`` in the tree, ``add_executable`` and ``add_library``,
``target_sources``, ``target_compile_definitions``/``add_compile_definitions``/``add_definitions``,
``target_include_directories``/``include_directories``, ``pico_add_extra_outputs``, and a library
of the file linked into an executable (``target_link_libraries``). Every branch of an ``if()``
counts (the reader does not evaluate conditions); ``add_subdirectory`` is not followed. A value
that needs what only a real configure knows (``${PICO_SDK_PATH}``, a generator expression
``$<...>``) is set aside as unresolved, never guessed.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Tuple

__all__ = ["CMakeError", "Target", "read_targets", "parse_commands"]

_UNKNOWN = "\x00"       # marks a value built from a variable this reader cannot know
# CMake's own words inside a command's arguments, which are not sources or values.
_SCOPES = {"PRIVATE", "PUBLIC", "INTERFACE"}
_EXE_FLAGS = {"WIN32", "MACOSX_BUNDLE", "EXCLUDE_FROM_ALL"}
_LIB_KINDS = {"STATIC", "SHARED", "MODULE", "OBJECT", "INTERFACE", "EXCLUDE_FROM_ALL"}


class CMakeError(ValueError):
    """A CMakeLists.txt this reader cannot read; the message is one line with the line number."""


@dataclass
class Target:
    name: str
    kind: str                                   # "executable" or "library"
    sources: List[str] = field(default_factory=list)
    definitions: List[str] = field(default_factory=list)
    include_dirs: List[str] = field(default_factory=list)
    links: List[str] = field(default_factory=list)
    line: int = 0                               # where it is declared
    chip_image: bool = False                    # pico_add_extra_outputs: made into the chip's image
    unresolved: List[str] = field(default_factory=list)   # values this reader could not know

    @property
    def sdk_outputs(self) -> bool:
        """Made into a chip image or linked with the pico-sdk (what a firmware is, not a host tool)."""
        return any(lib.startswith(("pico_", "hardware_")) for lib in self.links)


def _strip_comments(text: str) -> str:
    """The text with comments blanked out (line breaks kept, so line numbers stay right)."""
    out: List[str] = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(text[i:j + 1])
            i = j + 1
        elif c == "[" and re.match(r"\[=*\[", text[i:]):
            m = re.match(r"\[(=*)\[", text[i:])
            assert m is not None
            end = text.find("]" + m.group(1) + "]", i)
            end = n if end < 0 else end + len(m.group(1)) + 2
            out.append(text[i:end])
            i = end
        elif c == "#":
            m = re.match(r"#\[(=*)\[", text[i:])
            if m:
                end = text.find("]" + m.group(1) + "]", i)
                end = n if end < 0 else end + len(m.group(1)) + 2
            else:
                end = text.find("\n", i)
                end = n if end < 0 else end
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
        else:
            out.append(c)
            i += 1
    return "".join(out)


def parse_commands(text: str) -> List[Tuple[str, List[Tuple[str, bool]], int]]:
    """The file's commands in order: (name in lower case, [(argument, quoted)], line)."""
    body = _strip_comments(text)
    commands = []
    pos = 0
    head = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)[ \t]*\(")
    while True:
        m = head.search(body, pos)
        if m is None:
            return commands
        line = body.count("\n", 0, m.start()) + 1
        args: List[Tuple[str, bool]] = []
        i, depth, word = m.end(), 0, ""
        while True:
            if i >= len(body):
                raise CMakeError(f"line {line}: {m.group(1)}( is never closed")
            c = body[i]
            if c == '"':
                j = i + 1
                while j < len(body) and body[j] != '"':
                    j += 2 if body[j] == "\\" else 1
                args.append((re.sub(r"\\(.)", r"\1", body[i + 1:j]), True))
                i = j + 1
                continue
            bracket = re.match(r"\[(=*)\[", body[i:]) if not word else None
            if bracket:
                end = body.find("]" + bracket.group(1) + "]", i)
                if end < 0:
                    raise CMakeError(f"line {line}: a [[ argument is never closed")
                args.append((body[i + bracket.end():end], True))
                i = end + len(bracket.group(1)) + 2
                continue
            if c == "(":
                depth += 1
            elif c == ")":
                if depth == 0:
                    if word:
                        args.append((word, False))
                    break
                depth -= 1
            if c.isspace() and depth == 0:
                if word:
                    args.append((word, False))
                word = ""
            else:
                word += c
            i += 1
        commands.append((m.group(1).lower(), args, line))
        pos = i + 1


def _expand(value: str, variables: Dict[str, str]) -> str:
    """``${NAME}`` replaced, innermost first; an unknown one leaves the unknown mark."""
    for _ in range(20):
        m = re.search(r"\$\{([^${}]*)\}", value)
        if m is None:
            break
        got = variables.get(m.group(1))
        got = got if got is not None else _UNKNOWN + m.group(1) + _UNKNOWN
        value = value[:m.start()] + got + value[m.end():]
    return value


def _values(args: List[Tuple[str, bool]], variables: Dict[str, str]) -> List[str]:
    """The arguments as CMake hands them to a command: expanded, and an unquoted one split at ``;``."""
    out: List[str] = []
    for raw, quoted in args:
        value = _expand(raw, variables)
        if quoted:
            out.append(value)
        else:
            out.extend(v for v in value.split(";") if v)
    return out


def _glob(tree: Path, patterns: List[str], recurse: bool) -> List[str]:
    found: List[str] = []
    for pattern in patterns:
        if _UNKNOWN in pattern:
            continue
        rel = _relative(pattern, tree)
        if rel is None:
            continue
        hits = tree.rglob(rel) if recurse else tree.glob(rel)
        found.extend(sorted(str(p.relative_to(tree)) for p in hits if p.is_file()))
    return found


def _relative(path: str, tree: Path) -> Optional[str]:
    """``path`` relative to the tree's folder, or None when it lies outside it."""
    p = Path(path)
    if not p.is_absolute():
        return path
    try:
        return str(p.relative_to(tree))
    except ValueError:
        return None


def read_targets(text: str, tree: Path) -> List[Target]:
    """The executables and libraries ``text`` (a CMakeLists.txt of ``tree``) declares, in order,
    with what the file gives each."""
    here = str(tree)
    variables: Dict[str, str] = {name: here for name in (
        "CMAKE_CURRENT_LIST_DIR", "CMAKE_CURRENT_SOURCE_DIR", "CMAKE_SOURCE_DIR", "PROJECT_SOURCE_DIR",
        "CMAKE_HOME_DIRECTORY")}
    targets: Dict[str, Target] = {}
    shared_defs: List[str] = []
    shared_dirs: List[str] = []
    for name, args, line in parse_commands(text):
        values = _values(args, variables)
        if name == "project" and values:
            variables["PROJECT_NAME"] = variables.setdefault("CMAKE_PROJECT_NAME", values[0])
            variables[f"{values[0]}_SOURCE_DIR"] = here
        elif name == "set" and values:
            rest = values[1:]
            for stop in ("CACHE", "PARENT_SCOPE"):
                if stop in rest:
                    rest = rest[:rest.index(stop)]
            variables[values[0]] = ";".join(rest)
        elif name == "list" and len(values) >= 2 and values[0].upper() in ("APPEND", "PREPEND"):
            old = [v for v in variables.get(values[1], "").split(";") if v]
            new = values[2:] + old if values[0].upper() == "PREPEND" else old + values[2:]
            variables[values[1]] = ";".join(new)
        elif name == "file" and len(values) >= 3 and values[0].upper() in ("GLOB", "GLOB_RECURSE"):
            patterns = [v for v in values[2:] if v != "CONFIGURE_DEPENDS"]
            if "RELATIVE" in patterns:
                at = patterns.index("RELATIVE")
                patterns = patterns[:at] + patterns[at + 2:]
            found = _glob(tree, patterns, values[0].upper() == "GLOB_RECURSE")
            variables[values[1]] = ";".join(str(tree / f) for f in found)
        elif name in ("add_executable", "add_library") and values:
            if "IMPORTED" in values or "ALIAS" in values:
                continue
            skip = _EXE_FLAGS if name == "add_executable" else _LIB_KINDS
            target = targets.setdefault(values[0], Target(values[0], name[4:], line=line))
            target.sources += [v for v in values[1:] if v not in skip]
        elif name == "target_sources" and values and values[0] in targets:
            targets[values[0]].sources += [v for v in values[1:] if v not in _SCOPES]
        elif name == "target_compile_definitions" and values and values[0] in targets:
            targets[values[0]].definitions += [v for v in values[1:] if v not in _SCOPES]
        elif name == "target_include_directories" and values and values[0] in targets:
            targets[values[0]].include_dirs += [v for v in values[1:]
                                                if v not in _SCOPES | {"SYSTEM", "BEFORE", "AFTER"}]
        elif name == "target_link_libraries" and values and values[0] in targets:
            targets[values[0]].links += [v for v in values[1:] if v not in _SCOPES]
        elif name == "pico_add_extra_outputs" and values and values[0] in targets:
            targets[values[0]].chip_image = True
        elif name == "add_compile_definitions":
            shared_defs += values
        elif name == "add_definitions":
            shared_defs += [v[2:] for v in values if v.startswith("-D")]
        elif name == "include_directories":
            shared_dirs += [v for v in values if v not in ("SYSTEM", "BEFORE", "AFTER")]
    for target in targets.values():
        target.definitions = shared_defs + target.definitions
        target.include_dirs = shared_dirs + target.include_dirs
        for lib in target.links:             # a library of this file linked in: its sources too
            other = targets.get(lib)
            if other is not None and other.kind == "library" and other is not target:
                target.sources += other.sources
                target.definitions += [d for d in other.definitions if d not in target.definitions]
                target.include_dirs += [d for d in other.include_dirs if d not in target.include_dirs]
        _set_aside_unknown(target, tree)
    return list(targets.values())


def _set_aside_unknown(target: Target, tree: Path) -> None:
    """Values this reader cannot know leave the lists for ``unresolved`` (said, never guessed)."""
    def known(value: str) -> bool:
        if _UNKNOWN in value or "$<" in value:
            said = re.sub(_UNKNOWN + r"([^" + _UNKNOWN + r"]*)" + _UNKNOWN, r"${\1}", value)
            target.unresolved.append(said)
            return False
        return True

    sources, dirs = [], []
    for s in target.sources:
        if known(s):
            rel = _relative(s, tree)
            if rel is None:
                target.unresolved.append(s)
            elif rel not in sources:
                sources.append(rel)
    for d in target.include_dirs:
        if known(d):
            rel = _relative(d, tree)
            if rel is not None and rel not in dirs:
                dirs.append(rel)
    target.sources = sources
    target.include_dirs = dirs
    target.definitions = [d for d in target.definitions if known(d)]
