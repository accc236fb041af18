"""The package's folders form a line: a folder imports only folders below it, read from the source
(ast), imports inside functions, under TYPE_CHECKING and by name (``importlib.import_module``,
pytest ``-p``/``pytest_plugins`` strings) included.

    protocol <- harness <- transcripts <- emulator <- sil, rp2040 <- fuzz, conformance <- bench <- CLI

The root package (buildhat_conformance/*.py, the CLI) is the only place that names every folder.
fuzz and conformance stand side by side: neither imports the other.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path
from typing import Dict, List, Optional, Set, Tuple

from repo_paths import REPO

PACKAGE = "buildhat_conformance"
ROOT = ""                                   # the root package's own modules (buildhat_conformance/)
RANK = {"plumbing": 0, "protocol": 1, "harness": 2, "transcripts": 3, "serving": 4, "emulator": 5, "sil": 6,
        "rp2040": 7, "fuzz": 8, "conformance": 8, "campaigns": 9, "bench": 10, ROOT: 11}
BY_NAME = re.compile(rf"^{PACKAGE}\.(\w+)")
# The root package's modules (the CLI); another name after the package's (an entry-point group)
# is not a module.
ROOT_MODULES = {p.stem for p in (REPO / PACKAGE).glob("*.py")}


def folder_of(path: Path) -> str:
    top = path.relative_to(REPO).parts[0]
    return ROOT if top == PACKAGE else top


def _module_parts(path: Path) -> List[str]:
    """The package parts a relative import in ``path`` starts from."""
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[0] == PACKAGE:
        parts = parts[1:]
    return parts[:-1]       # a module's package, or (the __init__ dropped) the package itself


def imported_folders(path: Path, source: Optional[str] = None) -> Set[Tuple[str, int]]:
    """(folder, line) of every import of the package in ``path`` (``source`` instead of the file's
    text, for a planted module)."""
    text = path.read_text(encoding="utf-8") if source is None else source
    tree = ast.parse(text, str(path))
    here = _module_parts(path)
    found: Set[Tuple[str, int]] = set()
    # `python -m buildhat_conformance.cli ...`: the user's command in a child process, not an import
    commands = {id(seq.elts[i + 1]) for seq in ast.walk(tree) if isinstance(seq, (ast.List, ast.Tuple))
                for i, item in enumerate(seq.elts[:-1])
                if isinstance(item, ast.Constant) and item.value == "-m"}
    for node in ast.walk(tree):
        if not isinstance(node, (ast.stmt, ast.expr)):    # imports and names are these: they have a line
            continue
        names: List[str] = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level + 1]
                if node.module:
                    names = [".".join(base + [node.module])]
                else:   # from .. import a, b: a and b may be folders
                    names = [".".join(base + [a.name]) for a in node.names]
            elif node.module and node.module.startswith(PACKAGE + "."):
                names = [node.module[len(PACKAGE) + 1:]]
            elif node.module == PACKAGE:
                names = [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name[len(PACKAGE) + 1:] for a in node.names if a.name.startswith(PACKAGE + ".")]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in commands:
            # by name: importlib.import_module("buildhat_conformance.x"), "-p", pytest_plugins
            m = BY_NAME.match(node.value.strip())
            if m:
                names = [m.group(1)]
        for name in names:
            top = name.split(".")[0] if name else ROOT
            if top in RANK:
                found.add((top, node.lineno))
            elif top in ROOT_MODULES:
                found.add((ROOT, node.lineno))
    return found


def backward_imports(paths: List[Path]) -> List[str]:
    """``path:line: folder imports folder`` for every import of a folder not below the importer's."""
    bad = []
    for path in paths:
        mine = folder_of(path)
        for folder, line in sorted(imported_folders(path)):
            if folder != mine and RANK[folder] >= RANK[mine]:
                bad.append(f"{path.relative_to(REPO)}:{line}: {mine or PACKAGE} imports {folder or PACKAGE}")
    return bad


def package_files() -> List[Path]:
    tops = [t for t in RANK if t] + [PACKAGE]
    return sorted(p for top in tops for p in (REPO / top).rglob("*.py") if "__pycache__" not in p.parts)


def test_every_folder_of_the_package_has_a_rank():
    # A new folder in setup.py must take its place in the line here.
    setup = (REPO / "setup.py").read_text(encoding="utf-8")
    folders = ast.literal_eval(re.search(r"^FOLDERS = (\[.*?\])", setup, re.M | re.S).group(1))
    assert set(folders) == set(RANK) - {ROOT}


def test_the_reader_sees_the_known_imports():
    # Guards the reader itself: one that saw nothing would pass the rule below.
    seen: Dict[str, Set[str]] = {}
    for path in package_files():
        seen.setdefault(str(path.relative_to(REPO)), set()).update(f for f, _ in imported_folders(path))
    assert "harness" in seen["transcripts/record.py"]
    assert "protocol" in seen["harness/session.py"]
    assert "emulator" in seen["sil/target.py"]
    assert {"conformance", "fuzz", "bench", "transcripts"} <= seen["buildhat_conformance/cli.py"]  # by name
    assert "plumbing" in seen["conformance/report/__init__.py"]    # a lazy import inside a function


def test_a_planted_backward_import_is_found(tmp_path):
    # Lazy, typing-only and by-name imports count as much as a module-level one.
    planted = REPO / "harness" / "targets" / "planted.py"      # never written: read from source
    source = ("from typing import TYPE_CHECKING\n"
              "if TYPE_CHECKING:\n"
              "    from ...transcripts.script import Script\n"
              "def make():\n"
              "    from ...emulator import Emulator\n"
              "    import importlib\n"
              "    return importlib.import_module('buildhat_conformance.conformance.runner')\n"
              "from ..session import Session\n"
              "from ...protocol import profiles\n")
    found = imported_folders(planted, source)
    assert {f for f, _ in found} == {"transcripts", "emulator", "conformance", "harness", "protocol"}
    assert ("emulator", 5) in found
    bad = [f for f, _ in found if RANK[f] > RANK["harness"]]
    assert sorted(bad) == ["conformance", "emulator", "transcripts"]


def test_peers_and_the_root_are_above_or_beside():
    # fuzz and conformance share a rank: an import either way is as backward as an upward one.
    planted = REPO / "fuzz" / "planted.py"
    found = imported_folders(planted, "from ..conformance.link import Hat\nfrom .. import cli\n")
    assert {f for f, _ in found} == {"conformance", ROOT}
    assert all(RANK[f] >= RANK["fuzz"] for f, _ in found)


def test_no_folder_imports_one_above_it():
    bad = backward_imports(package_files())
    assert not bad, ("imports against the folder order (tests/project/test_package_layering.py):\n"
                     + "\n".join(bad))
