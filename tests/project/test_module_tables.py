"""Every folder's README has a complete module table (issue #36): a newcomer finds each module, and
what it is for, in one place per folder.

The table is the one under a ``## Modules`` heading: rows ``| `path` | job |`` (or several paths in
the first cell), each relative to the folder, a pattern allowed for a family (``cases/test_*.py``);
rows naming other files (C sources, data) are the README's business. Every module of the folder
(sub-folders included; a package's ``__init__.py`` only when it holds more than its docstring)
has a row, and every row names modules that exist.
"""
from __future__ import annotations

import ast
import fnmatch
import re
from pathlib import Path
from typing import List, Set

import pytest
from repo_paths import PACKAGE, REPO, package_folders

ROW = re.compile(r"^\|(?P<names>\s*`[^|]+)\|(?P<job>[^|]*(?:\\\|[^|]*)*)\|\s*$")
NAME = re.compile(r"`([^`]+)`")


def table_rows(readme: Path) -> List[tuple]:
    """``(path, job)`` of each row of the README's ``## Modules`` table."""
    rows, inside = [], False
    for line in readme.read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            inside = line.strip() == "## Modules"
            continue
        m = ROW.match(line) if inside else None
        if m:       # a row may name several modules: | `a.py`, `b.py` | job |
            rows.extend((name, m.group("job").strip()) for name in NAME.findall(m.group("names")))
    return rows


def _only_a_docstring(path: Path) -> bool:
    body = ast.parse(path.read_text(encoding="utf-8")).body
    return all(isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant) for n in body)


def modules(folder: Path) -> Set[str]:
    """The folder's modules, relative to it (the root package: its own files only)."""
    paths = folder.glob("*.py") if folder.name == PACKAGE else folder.rglob("*.py")
    return {str(p.relative_to(folder)) for p in paths if "__pycache__" not in p.parts
            and not (p.name == "__init__.py" and _only_a_docstring(p))}


def missing_and_unknown(folder: Path) -> tuple:
    rows = table_rows(folder / "README.md")
    names = [path for path, _job in rows]
    have = modules(folder)
    missing = sorted(m for m in have if not any(fnmatch.fnmatch(m, n) for n in names))
    unknown = sorted(n for n in names if n.endswith(".py") and not any(fnmatch.fnmatch(m, n) for m in have))
    empty = sorted(path for path, job in rows if not job)
    return missing, unknown, empty


@pytest.mark.parametrize("name", package_folders(REPO))
def test_every_module_is_in_its_folders_table(name: str) -> None:
    folder = REPO / name
    assert (folder / "README.md").is_file(), f"{name}/ has no README.md"
    missing, unknown, empty = missing_and_unknown(folder)
    assert not missing, f"{name}/README.md's module table lacks: {missing}"
    assert not unknown, f"{name}/README.md's module table names modules that do not exist: {unknown}"
    assert not empty, f"{name}/README.md's module table says nothing of: {empty}"


def test_the_check_sees_a_module_left_out(tmp_path: Path) -> None:
    # Guards the check: a planted folder whose table forgets one module and names a gone one.
    (tmp_path / "sub").mkdir()
    (tmp_path / "a.py").write_text("x = 1\n", encoding="utf-8")
    (tmp_path / "sub" / "b.py").write_text("y = 2\n", encoding="utf-8")
    (tmp_path / "sub" / "__init__.py").write_text('"""only a docstring"""\n', encoding="utf-8")
    (tmp_path / "README.md").write_text("# x\n\n## Modules\n\n| module | job |\n|---|---|\n"
                                        "| `a.py` | the a |\n| `gone.py` | was here |\n\n## Other\n"
                                        "| `sub/b.py` | not in the table's section |\n", encoding="utf-8")
    assert missing_and_unknown(tmp_path) == (["sub/b.py"], ["gone.py"], [])
