"""What the sil tests share: the firmware tree from shared/ and the user's command."""
import os
import pathlib
import shutil
import subprocess
import sys
from typing import List

import pytest
from junit_props import properties
from shared_material import need_shared

TREE_NAME = "firmware-pico-1737564117"
CLI = [sys.executable, "-m", "buildhat_conformance.cli"]


def firmware_tree() -> pathlib.Path:
    tree = need_shared("firmware", TREE_NAME, what="a firmware tree")
    if not (shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")):
        pytest.skip("no C compiler on this machine")
    return tree


def copy_tree(dest: pathlib.Path) -> pathlib.Path:
    shutil.copytree(firmware_tree(), dest)
    return dest


def plant(tree: pathlib.Path, name: str, old: str, new: str) -> None:
    """Change one place of a copied tree's C file (the test's own planted regression)."""
    path = tree / name
    text = path.read_text()
    assert text.count(old) == 1, f"{old!r} is not in {name} exactly once"
    path.write_text(text.replace(old, new))


def cli(*args: str, cache: pathlib.Path, timeout: float = 600) -> subprocess.CompletedProcess:
    env = dict(os.environ, BUILDHAT_SIL_CACHE=str(cache))
    return subprocess.run(CLI + list(args), capture_output=True, text=True, env=env, timeout=timeout)


def junit_verdicts(path: pathlib.Path) -> List[tuple]:
    import xml.etree.ElementTree as ET
    out = []
    for case in ET.parse(path).getroot().iter("testcase"):
        props = properties(case)
        message = next((c.get("message") or "" for c in case if c.tag in ("failure", "error", "skipped")), "")
        out.append((case.get("name"), props.get("verdict"), message))
    return out


def whole_suite(cache: pathlib.Path, folder: pathlib.Path, options: str = "") -> tuple:
    """The whole suite on the R7 tree (``options``: the URL's ``?...``): the command and its verdicts."""
    junit = folder / "junit.xml"
    done = cli("run", "--target", f"sil:{firmware_tree()}{options}", "--junit", str(junit), cache=cache,
               timeout=900)
    return done, junit_verdicts(junit)


BROKEN = "\nthis does not compile\n"


def git(repo: pathlib.Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True, text=True).stdout


def git_history(repo: pathlib.Path, folder: str, count: int, changed_at: int, broken=None) -> List[str]:
    """A repository of ``count`` commits ("commit 1" ...) of the R7 tree in ``folder`` (each changes a
    note file); commit ``changed_at`` changes the help text's vin line, commit ``broken`` adds a line
    that does not compile to main.c and the next one takes it out. Their SHAs, oldest first."""
    repo.mkdir()
    git(repo, "init", "-q")
    git(repo, "config", "user.email", "t@example.com")
    git(repo, "config", "user.name", "test")
    tree = repo / folder
    shutil.copytree(firmware_tree(), tree, dirs_exist_ok=True)
    shas = []
    for n in range(1, count + 1):
        (tree / "NOTES.txt").write_text(f"note {n}\n")
        if n == changed_at:
            plant(tree, "command.c", "report main power input voltage", "report main power input volts!!")
        if n == broken:
            (tree / "main.c").write_text((tree / "main.c").read_text() + BROKEN)
        if broken and n == broken + 1:
            (tree / "main.c").write_text((tree / "main.c").read_text().replace(BROKEN, ""))
        git(repo, "add", "-A")
        git(repo, "commit", "-q", "-m", f"commit {n}")
        shas.append(git(repo, "rev-parse", "HEAD").strip())
    return shas
