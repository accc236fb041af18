"""Which C files of a firmware tree make the firmware: the ones its ``CMakeLists.txt`` gives the
firmware's executable (with that file's compile definitions and include folders), or, without a
usable CMakeLists.txt, every C file of the folder.

Real trees carry C files the firmware's build leaves out (test programs with a ``main()`` of their
own, experiments, scratch files); those are left out here too, and named. Among several
executables the firmware is the one made into a chip image (``pico_add_extra_outputs``), then the
one linked with the pico-sdk, then the first. Without a usable CMakeLists.txt, a folder whose files
define ``main()`` more than once cannot be one program: the files that clash are named.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional

from .cmake_sources import CMakeError, Target, read_targets

__all__ = ["SourcePlan", "plan_sources", "defines_main", "CMAKELISTS"]

CMAKELISTS = "CMakeLists.txt"
EVERY_FILE = "every C file of the folder"       # the rule without a usable CMakeLists.txt
_MAIN = re.compile(r"^[ \t]*(?:int|void)[ \t\n]+main[ \t]*\(", re.MULTILINE)


@dataclass
class SourcePlan:
    sources: List[Path]                     # the C files to compile, in the CMakeLists' order
    left_out: List[Path] = field(default_factory=list)    # the tree's other C files
    definitions: List[str] = field(default_factory=list)  # NAME or NAME=VALUE
    include_dirs: List[Path] = field(default_factory=list)
    origin: str = EVERY_FILE                # what chose the sources
    note: Optional[str] = None              # why the CMakeLists.txt was not used, or what it left unsaid
    clash: List[Path] = field(default_factory=list)       # files that each define main()

    def left_out_line(self) -> Optional[str]:
        """One line naming the C files the build leaves out (None when none are)."""
        if not self.left_out:
            return None
        return f"left out: {', '.join(p.name for p in self.left_out)} (not in {self.origin})"

    def said(self) -> List[str]:
        """What ``sil build`` says beyond its first line: the files left out, and what of the
        CMakeLists.txt was not taken or why it was not used (nothing for a tree without one)."""
        lines = [self.left_out_line() or ""] if self.left_out else []
        if self.note:
            lines.append(self.note + (f": building {EVERY_FILE}" if self.origin == EVERY_FILE else ""))
        return lines

    def clash_line(self) -> str:
        return (f"{len(self.clash)} files define main(): {', '.join(p.name for p in self.clash)}; "
                f"they cannot make one program ({self.note or 'no CMakeLists.txt'}: give the tree a "
                f"{CMAKELISTS} whose add_executable names the firmware's files, or move the others out)")


def defines_main(source: Path) -> bool:
    """A ``main()`` defined at the start of a line (not a call, not a comment's word)."""
    return bool(_MAIN.search(source.read_text(encoding="utf-8", errors="replace")))


def _firmware(targets: List[Target]) -> Optional[Target]:
    executables = [t for t in targets if t.kind == "executable"]
    if not executables:
        return None
    return max(executables, key=lambda t: (t.chip_image, t.sdk_outputs, -executables.index(t)))


def plan_sources(tree: Path) -> SourcePlan:
    """The plan for ``tree`` (a firmware folder). Never raises: a plan with ``clash`` cannot link."""
    every = sorted(p for p in tree.iterdir() if p.is_file() and p.suffix == ".c")
    cmake = tree / CMAKELISTS
    note = None
    if cmake.is_file():
        try:
            text = cmake.read_text(encoding="utf-8", errors="replace")
            targets = read_targets(text, tree)
            chosen = _firmware(targets)
        except CMakeError as exc:
            chosen, note = None, f"{CMAKELISTS} unreadable ({exc})"
        if chosen is not None:
            plan = _from_target(chosen, tree, every, len([t for t in targets if t.kind == "executable"]))
            if plan is not None:
                return plan
            note = f"{CMAKELISTS}'s add_executable({chosen.name}) names no C file of the tree"
        elif note is None:
            note = f"{CMAKELISTS} has no add_executable"
    plan = SourcePlan(every, note=note)
    mains = [p for p in every if defines_main(p)]
    if len(mains) > 1:
        plan.clash = mains
    return plan


def _from_target(target: Target, tree: Path, every: List[Path], executables: int) -> Optional[SourcePlan]:
    sources = [tree / s for s in target.sources if s.endswith(".c") and (tree / s).is_file()]
    if not sources:
        return None
    missing = [s for s in target.sources if s.endswith(".c") and not (tree / s).is_file()]
    unsaid = [f"{s} (not in the tree)" for s in missing] + target.unresolved
    origin = f"{CMAKELISTS}'s add_executable({target.name})" + (
        f" (the firmware of its {executables} executables)" if executables > 1 else "")
    chosen = {p.resolve() for p in sources}
    return SourcePlan(
        sources=sources,
        left_out=[p for p in every if p.resolve() not in chosen],
        definitions=list(target.definitions),
        include_dirs=[tree / d for d in target.include_dirs if (tree / d).is_dir()],
        origin=origin,
        note=("not taken: " + ", ".join(unsaid)) if unsaid else None)
