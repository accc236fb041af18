"""The tests mirror the code (issue #26): every module of the package is imported by a test of its own
folder (``tests/<folder>/``, sub-folders included), or its folder's README names it on a coverage line
with the end-to-end test that covers it:

    Covered end to end: `cli.py`, `pytest_fixture.py` by `tests/end_to_end/test_emulator_processes.py`.

A name may be a pattern (`cases/test_*.py`: the suite's own cases, run whole by an end-to-end test).
The benchmarks alone may instead say that only ``make bench`` runs a module (timing lives there, and some
measures need a whole lab): ``Run by `make bench` only: `lab.py` (why).``

Imports are read from the source (ast): module level, inside functions, and ``importlib.import_module``
with a literal name. A package's ``__init__.py`` counts as imported when the package or anything in it is.
"""
from __future__ import annotations

import ast
import fnmatch
import pathlib
import re
from typing import Dict, Iterable, List, Set

import pytest
from repo_paths import PACKAGE, REPO, package_folders

# The package root's own modules (the CLI) are mirrored in tests/cli/; every other folder by its name.
TESTS_OF = {PACKAGE: "cli"}
COVERAGE_LINE = re.compile(r"^Covered end to end[^:]*:\s*(?P<modules>.+?)\s+by\s+(?P<tests>`.+)$")
BENCH_ONLY_LINE = re.compile(r"^Run by `make bench` only:\s*(?P<modules>.+)$")
BENCH_ONLY_FOLDERS = {"bench"}        # measures with no test of their own are allowed there alone


def modules_of(repo: pathlib.Path, folder: str) -> List[pathlib.Path]:
    root = repo / folder
    if folder == PACKAGE:          # the root package: its own files, not the folders mapped into it
        return sorted(root.glob("*.py"))
    return sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts)


def dotted(repo: pathlib.Path, path: pathlib.Path) -> str:
    """``emulator/devices/motor.py`` -> ``buildhat_conformance.emulator.devices.motor``."""
    rel = path.relative_to(repo).with_suffix("")
    parts = list(rel.parts)
    if parts[0] == PACKAGE:
        parts = parts[1:]
    if parts and parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join([PACKAGE, *parts])


def imported_names(source: str) -> Set[str]:
    """Every dotted name a test file imports, ``from X import y`` giving both ``X`` and ``X.y``."""
    names: Set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
        elif (isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None))
              == "import_module" and node.args and isinstance(node.args[0], ast.Constant)
              and isinstance(node.args[0].value, str)):
            names.add(node.args[0].value)
    return names


def covered_by_readme(readme: pathlib.Path, repo: pathlib.Path) -> Dict[str, List[str]]:
    """``{module path relative to the folder: [end-to-end tests named for it]}`` from the README's
    coverage lines."""
    found: Dict[str, List[str]] = {}
    if not readme.is_file():
        return found
    for line in readme.read_text(encoding="utf-8").splitlines():
        m = COVERAGE_LINE.match(line.strip())
        bench_only = BENCH_ONLY_LINE.match(line.strip())
        if m:
            tests = re.findall(r"`([^`]+)`", m.group("tests"))
            for module in re.findall(r"`([^`]+\.py)`", m.group("modules")):
                found.setdefault(module, []).extend(tests)
        elif bench_only and readme.parent.name in BENCH_ONLY_FOLDERS:
            for module in re.findall(r"`([^`]+\.py)`", bench_only.group("modules")):
                found.setdefault(module, [])
    return found


def uncovered(repo: pathlib.Path, folders: Iterable[str]) -> List[str]:
    """One line per module with neither a test of its own nor a coverage line, and per coverage line
    that names a module or an end-to-end test that does not exist."""
    problems: List[str] = []
    for folder in folders:
        tests_dir = repo / "tests" / TESTS_OF.get(folder, folder)
        names: Set[str] = set()
        for test in sorted(tests_dir.rglob("test_*.py")) if tests_dir.is_dir() else []:
            names |= imported_names(test.read_text(encoding="utf-8"))
        readme = repo / folder / "README.md"
        by_readme = covered_by_readme(readme, repo)
        for module, tests in by_readme.items():
            if not any(p.is_file() for p in (repo / folder).glob(module)):
                problems.append(f"{readme.relative_to(repo)}: names {module}, which does not exist")
            problems += [f"{readme.relative_to(repo)}: names {t} for {module}, which does not exist"
                         for t in tests if not (repo / t).is_file()]
        for path in modules_of(repo, folder):
            name = dotted(repo, path)
            is_package = path.name == "__init__.py"
            if name in names or (is_package and any(n.startswith(name + ".") for n in names)):
                continue
            inside = path.relative_to(repo / folder).as_posix()
            if any(fnmatch.fnmatchcase(inside, pattern) for pattern in by_readme):
                continue
            problems.append(f"{path.relative_to(repo)}: no test in {tests_dir.relative_to(repo)}/ imports "
                            f"it and {folder}/README.md has no coverage line for it")
    return problems


def test_every_module_has_a_test_of_its_own_or_a_coverage_line():
    problems = uncovered(REPO, package_folders(REPO))
    assert not problems, "\n".join(problems)


# -- the check itself, on a small planted tree ----------------------------------------------------

@pytest.fixture
def planted(tmp_path: pathlib.Path) -> pathlib.Path:
    (tmp_path / "setup.py").write_text('FOLDERS = ["widget"]\n', encoding="utf-8")
    for rel in ["buildhat_conformance/__init__.py", "widget/__init__.py", "widget/parts/__init__.py",
                "widget/parts/gear.py", "widget/spring.py", "widget/lever.py"]:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("", encoding="utf-8")
    (tmp_path / "tests" / "widget" / "parts").mkdir(parents=True)
    (tmp_path / "tests" / "cli").mkdir(parents=True)
    tests = tmp_path / "tests"
    (tests / "cli" / "test_init.py").write_text("import buildhat_conformance\n", encoding="utf-8")
    (tests / "widget" / "parts" / "test_gear.py").write_text(
        "def test_x():\n    from buildhat_conformance.widget.parts import gear\n", encoding="utf-8")
    (tests / "widget" / "test_spring.py").write_text(
        "import importlib\nS = importlib.import_module('buildhat_conformance.widget.spring')\n",
        encoding="utf-8")
    return tmp_path


def test_a_module_no_test_of_its_folder_imports_is_named(planted: pathlib.Path):
    # A test elsewhere importing widget/lever.py does not count: it is not a test of widget/.
    (planted / "tests" / "cli" / "test_other.py").write_text(
        "from buildhat_conformance.widget import lever\n", encoding="utf-8")
    assert uncovered(planted, package_folders(planted)) == [
        "widget/lever.py: no test in tests/widget/ imports it and widget/README.md has no coverage line "
        "for it"]


def test_a_coverage_line_covers_a_module_and_must_name_real_files(planted: pathlib.Path):
    (planted / "tests" / "end_to_end").mkdir()
    (planted / "tests" / "end_to_end" / "test_widget.py").write_text("", encoding="utf-8")
    readme = planted / "widget" / "README.md"
    readme.write_text("Covered end to end: `lever.py` by `tests/end_to_end/test_widget.py`.\n",
                      encoding="utf-8")
    assert uncovered(planted, package_folders(planted)) == []
    readme.write_text("Covered end to end: `l*.py` by `tests/end_to_end/test_widget.py`.\n", encoding="utf-8")
    assert uncovered(planted, package_folders(planted)) == []
    readme.write_text("Covered end to end: `lever.py`, `pulley.py` by `tests/end_to_end/test_gone.py`.\n",
                      encoding="utf-8")
    assert uncovered(planted, package_folders(planted)) == [
        "widget/README.md: names tests/end_to_end/test_gone.py for lever.py, which does not exist",
        "widget/README.md: names pulley.py, which does not exist",
        "widget/README.md: names tests/end_to_end/test_gone.py for pulley.py, which does not exist"]


def test_only_the_benchmarks_may_leave_a_module_to_make_bench(planted: pathlib.Path):
    (planted / "widget" / "README.md").write_text("Run by `make bench` only: `lever.py` (a lab).\n",
                                                  encoding="utf-8")
    assert [p.split(":")[0] for p in uncovered(planted, package_folders(planted))] == ["widget/lever.py"]
    (planted / "setup.py").write_text('FOLDERS = ["bench"]\n', encoding="utf-8")
    (planted / "widget").rename(planted / "bench")
    (planted / "tests" / "widget").rename(planted / "tests" / "bench")
    for test in (planted / "tests" / "bench").rglob("test_*.py"):
        test.write_text(test.read_text(encoding="utf-8").replace(".widget", ".bench"), encoding="utf-8")
    assert uncovered(planted, package_folders(planted)) == []
