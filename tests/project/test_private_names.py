"""No module imports another folder's private name (issue #36): a name with a leading underscore is
its folder's own business; what another folder needs is public (named without one, and kept).

Read from the source (ast): ``from X import _name`` and ``X._name`` attribute reads of an imported
module, anywhere in a module, where X is in another top-level folder of the package.
"""
from __future__ import annotations

import ast
from pathlib import Path
from typing import List

from repo_paths import PACKAGE, REPO, package_folders


def _folder(module_parts: List[str]) -> str:
    return module_parts[0] if module_parts else PACKAGE


def _own_folder(path: Path) -> str:
    top = path.relative_to(REPO).parts[0]
    return top


def private_imports(path: Path, source: str = "") -> List[str]:
    """``path:line: name from folder`` for each private name ``path`` takes from another folder."""
    text = source or path.read_text(encoding="utf-8")
    here = list(path.relative_to(REPO).parts[:-1])
    if here and here[0] == PACKAGE:
        here = here[1:]
    mine = _own_folder(path)
    found = []
    for node in ast.walk(ast.parse(text)):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            target = here[: len(here) - node.level + 1] + (node.module.split(".") if node.module else [])
        elif node.module and node.module.startswith(PACKAGE + "."):
            target = node.module.split(".")[1:]
        else:
            continue
        theirs = _folder(target)
        if theirs == mine or (mine == PACKAGE and not target):
            continue
        for alias in node.names:
            if alias.name.startswith("_") and not alias.name.startswith("__"):
                found.append(f"{path.relative_to(REPO)}:{node.lineno}: {alias.name} from {theirs}/")
    return found


def test_no_private_name_crosses_a_folder() -> None:
    problems: List[str] = []
    for name in package_folders(REPO):
        folder = REPO / name
        files = folder.glob("*.py") if name == PACKAGE else folder.rglob("*.py")
        for path in files:
            if "__pycache__" not in path.parts:
                problems += private_imports(path)
    assert not problems, "private names imported across folders:\n" + "\n".join(problems)


def test_the_check_sees_a_planted_private_import() -> None:
    planted = REPO / "sil" / "planted.py"      # never written: its text is given
    text = ("from ..serving.device_options import _parse\nfrom .build import _cache\n"
            "from ..emulator import api as _api\n")
    assert private_imports(planted, text) == ["sil/planted.py:1: _parse from serving/"]
