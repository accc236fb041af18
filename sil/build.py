"""Build a firmware tree for the host: the C files the tree's own build makes the firmware of
(``tree_sources.py``: its CMakeLists.txt, or every C file without one), unchanged, against the
stand-in (``standin/``), with the system C compiler. Nothing in the tree is written. A failed
compile or link is one line with the tool's own cause (``build_messages.py``).

The result is cached by the content of the tree (its .c/.h/.pio files, its CMakeLists.txt and
the sources it names elsewhere in the tree), the stand-in's sources, the flags and the
compiler's version, under ``$BUILDHAT_SIL_CACHE`` or ``~/.cache/buildhat-conformance/sil``.
Options: sanitizers (``address``, ``undefined``) and gcov coverage (the firmware's files only;
the data is written when the program exits).
"""
from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import re
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from .asm_cost import charge_soft_float
from .build_messages import compile_failure, link_failure
from .float_convert import rewrite_conversions
from .pio_header import pio_header
from .tree_sources import CMAKELISTS, SourcePlan, plan_sources

__all__ = ["BuildError", "Build", "build_tree", "find_tree", "standin_dir", "cache_root",
           "SANITIZERS", "find_compiler", "tree_version", "program_version"]

SANITIZERS = ("address", "undefined")
PROGRAM = "firmware"
VERSION_NOTE = "version.txt"
COMMON = ["-std=gnu11", "-g", "-fno-omit-frame-pointer", "-fno-strict-aliasing"]
# -fsanitize-coverage=trace-pc is the stand-in's clock (standin/machine.c).
# -funsigned-char: plain char is unsigned in the ARM EABI the firmware is written for.
FIRMWARE = ["-fsanitize-coverage=trace-pc", "-mno-red-zone", "-funsigned-char", "-w"]
STANDIN = ["-Wall", "-Wextra"]


class BuildError(RuntimeError):
    """A build that could not be done; the message is one line saying why."""


@dataclass
class Build:
    program: Path
    tree: Path
    folder: Path
    cached: bool
    sanitize: Tuple[str, ...] = ()
    coverage: bool = False
    sources: List[Path] = field(default_factory=list)
    version: Optional[str] = None      # the release number the tree's version.h names
    plan: Optional[SourcePlan] = None  # which C files, and why (left out, definitions, include folders)


def tree_version(tree: Path) -> Optional[str]:
    """The 10-digit release number in the tree's version header (what `version` prints first)."""
    for header in sorted(tree.glob("version*.h")):
        m = re.search(r"\b(\d{10})\b", header.read_text(encoding="utf-8", errors="replace"))
        if m:
            return m.group(1)
    return None


def program_version(program: Path) -> Optional[str]:
    """The release number recorded beside a built program (None: unknown)."""
    note = program.with_name(VERSION_NOTE)
    return note.read_text(encoding="utf-8").strip() or None if note.exists() else None


def standin_dir() -> Path:
    return Path(__file__).resolve().parent / "standin"


def cache_root() -> Path:
    given = os.environ.get("BUILDHAT_SIL_CACHE")
    if given:
        return Path(given)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "buildhat-conformance" / "sil"


def find_tree(path: str) -> Path:
    """The firmware folder: ``path`` itself, or its ``firmware-pico/`` (a checkout)."""
    p = Path(path).expanduser()
    if not p.exists():
        raise BuildError(f"{path}: no such folder")
    if p.is_file():
        raise BuildError(f"{path}: a file, not a firmware tree "
                         "(give the folder with the firmware's .c files)")
    for candidate in (p, p / "firmware-pico"):
        sources = sorted(candidate.glob("*.c")) if candidate.is_dir() else []
        if sources and any(_defines_main(s) for s in sources) and any(_uses_sdk(s) for s in sources):
            return candidate.resolve()
    raise BuildError(f"{path}: not a Build HAT firmware tree (no C files with main() that include "
                     "pico-sdk headers, here or in firmware-pico/)")


def _defines_main(source: Path) -> bool:
    text = source.read_text(encoding="utf-8", errors="replace")
    return "main(" in text and ("int main" in text or "void main" in text)


def _uses_sdk(source: Path) -> bool:
    text = source.read_text(encoding="utf-8", errors="replace")
    return '"pico/' in text or '"hardware/' in text or "<pico/" in text or "<hardware/" in text


def find_compiler() -> str:
    for name in filter(None, [os.environ.get("CC"), "cc", "gcc", "clang"]):
        found = shutil.which(name)
        if found:
            return found
    raise BuildError("no C compiler found: install gcc or clang (or set CC)")


@functools.lru_cache(maxsize=8)
def _compiler_version(cc: str) -> str:
    try:
        out = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise BuildError(f"{cc} does not run: {exc}") from None
    return out.stdout.splitlines()[0] if out.stdout else cc


def _flags(sanitize: Sequence[str], coverage: bool) -> Tuple[List[str], List[str], List[str]]:
    opt = ["-O0"] if coverage else ["-O1"]
    san = [f"-fsanitize={','.join(sanitize)}", "-fno-sanitize-recover=all"] if sanitize else []
    fw = COMMON + opt + FIRMWARE + san + (["--coverage"] if coverage else [])
    st = COMMON + opt + STANDIN + san
    link = san + (["--coverage"] if coverage else [])
    return fw, st, link


def _tree_files(tree: Path) -> List[Path]:
    return sorted(p for p in tree.iterdir() if p.is_file() and p.suffix in (".c", ".h", ".pio"))


def _plan_flags(tree: Path, plan: SourcePlan) -> List[str]:
    """The CMakeLists' compile definitions and the tree's include folders it names."""
    return [f"-D{d}" for d in plan.definitions] + [a for d in plan.include_dirs for a in ("-I", str(d))]


def _key(tree: Path, cc: str, flags: Sequence[str], plan: Optional[SourcePlan] = None) -> str:
    h = hashlib.sha256()
    h.update(_compiler_version(cc).encode())
    h.update("\0".join(flags).encode())
    files = _tree_files(tree) + [tree / CMAKELISTS]
    if plan is not None:
        # sources and headers the CMakeLists names outside the tree's top folder
        files += [p for p in plan.sources if p.parent != tree]
        files += [h for d in plan.include_dirs if d != tree for h in sorted(d.glob("*.h"))]
    for p in files:
        if p.is_file():
            h.update(str(p.relative_to(tree)).encode() + b"\0" + p.read_bytes() + b"\0")
    for p in sorted(standin_dir().rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(standin_dir())).encode() + b"\0" + p.read_bytes())
    for helper in ("pio_header.py", "float_convert.py", "asm_cost.py"):
        h.update(Path(__file__).with_name(helper).read_bytes())
    return h.hexdigest()[:20]


def _first_error(stderr: str) -> str:
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    for ln in lines:
        if "error" in ln.lower():
            return ln
    return lines[0] if lines else "the compiler failed without a message"


def _compile(cc: str, args: List[str], what: str,
             explain: Optional[Callable[[str], Optional[str]]] = None) -> None:
    """Run the compiler; a failure is a BuildError saying ``what`` and the cause in one line
    (``explain``'s reading of the tool's output where it has one, else the first error line)."""
    try:
        out = subprocess.run([cc] + args, capture_output=True, text=True, timeout=300)
    except subprocess.TimeoutExpired:
        raise BuildError(f"{what}: the compiler took more than 300 s") from None
    if out.returncode != 0:
        said = explain(out.stderr) if explain is not None else None
        raise BuildError(f"{what}: {said or _first_error(out.stderr)}")


def _object_stem(tree: Path, src: Path) -> str:
    """A file in a subfolder gets its folder in its object's name (two ``util.c`` stay apart)."""
    return "__".join(src.relative_to(tree).with_suffix("").parts)


def _build_into(folder: Path, tree: Path, sources: List[Path], cc: str, fw_flags: List[str],
                st_flags: List[str], link_flags: List[str], base: Optional[Build] = None,
                plan: Optional[SourcePlan] = None) -> None:
    plan = plan or SourcePlan(sources)
    left_out, origin = plan.left_out, plan.origin

    def gap(stderr: str) -> Optional[str]:
        return compile_failure(stderr, tree, plan.sources, left_out, origin)

    fw_flags = fw_flags + _plan_flags(tree, plan)
    objects_of: Dict[str, str] = {}
    gen = folder / "gen"
    gen.mkdir(exist_ok=True)
    for pio in tree.glob("*.pio"):
        (gen / f"{pio.name}.h").write_text(pio_header(pio), encoding="utf-8")
    inc = standin_dir() / "include"
    objects: List[str] = []
    for src in sources:
        stem = _object_stem(tree, src)
        asm, obj = folder / f"fw_{stem}.s", folder / f"fw_{stem}.o"
        objects_of[obj.name] = src.name
        if base is not None and _same_source(base, src, stem):
            shutil.copyfile(base.folder / obj.name, obj)      # a mutant: only its changed file is compiled
            objects.append(str(obj))
            continue
        _compile(cc, fw_flags + ["-I", str(gen), "-I", str(inc), "-I", str(tree), "-S", str(src),
                                 "-o", str(asm)], src.name, gap)
        # The chip's float conversions saturate (float_convert.py): the compiler's output is
        # rewritten, the tree's source is not touched.
        text, _count = rewrite_conversions(asm.read_text(encoding="utf-8"), stem)
        text, _blocks = charge_soft_float(text)      # the chip's float is software (asm_cost.py)
        asm.write_text(text, encoding="utf-8")
        _compile(cc, fw_flags + ["-c", str(asm), "-o", str(obj)], f"{src.name} (assembling)")
        objects.append(str(obj))
    for src in sorted(standin_dir().glob("*.c")):
        obj = folder / f"sil_{src.stem}.o"
        if base is not None and (base.folder / obj.name).is_file():
            shutil.copyfile(base.folder / obj.name, obj)      # the same stand-in, the same flags
            objects.append(str(obj))
            continue
        _compile(cc, st_flags + ["-I", str(inc), "-I", str(standin_dir()), "-c", str(src), "-o", str(obj)],
                 f"stand-in {src.name}")
        objects.append(str(obj))
    _compile(cc, objects + link_flags + ["-o", str(folder / (PROGRAM + ".tmp"))], "linking",
             lambda stderr: link_failure(stderr, tree, objects_of, plan.sources, left_out, origin))


def _same_source(base: Build, src: Path, stem: str) -> bool:
    other = base.tree / src.name
    return (stem == src.stem and other.is_file() and (base.folder / f"fw_{stem}.o").is_file()
            and other.read_bytes() == src.read_bytes())


def build_tree(path: str, sanitize: Sequence[str] = (), coverage: bool = False,
               cache: Optional[Path] = None, base: Optional[Build] = None) -> Build:
    """Build (or find in the cache) the host program of the firmware tree at ``path``.
    ``base``: a build of the same flags whose objects may be reused for unchanged files."""
    bad = [s for s in sanitize if s not in SANITIZERS]
    if bad:
        raise BuildError(f"unknown sanitizer {bad[0]!r} (known: {', '.join(SANITIZERS)})")
    sanitize = tuple(s for s in SANITIZERS if s in sanitize)
    tree = find_tree(path)
    plan = plan_sources(tree)
    if plan.clash:
        raise BuildError(plan.clash_line())
    cc = find_compiler()
    fw_flags, st_flags, link_flags = _flags(sanitize, coverage)
    # the plan's flags with the tree's folders relative: a copy of the tree elsewhere is the same build
    named = [f"-D{d}" for d in plan.definitions] + [f"-I{d.relative_to(tree)}" for d in plan.include_dirs]
    key = _key(tree, cc, fw_flags + st_flags + link_flags + named, plan)
    root = cache or cache_root()
    folder = root / key
    program = folder / PROGRAM
    sources = plan.sources
    version = tree_version(tree)
    if program.exists():
        return Build(program, tree, folder, True, sanitize, coverage, sources, version, plan)
    folder.mkdir(parents=True, exist_ok=True)
    # Built in place (gcov records the object paths), under a lock: two runs of the same build
    # at once wait for each other instead of racing.
    with open(folder / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if program.exists():
            return Build(program, tree, folder, True, sanitize, coverage, sources, version, plan)
        _build_into(folder, tree, sources, cc, fw_flags, st_flags, link_flags, base, plan)
        (folder / VERSION_NOTE).write_text((version or "") + "\n", encoding="utf-8")
        os.replace(folder / (PROGRAM + ".tmp"), program)
    return Build(program, tree, folder, False, sanitize, coverage, sources, version, plan)
