"""No citation of a file the repository does not contain (issue #36): users have the project, not the
developers' material beside it, so the package (every file it ships), docs/*.md and every folder README
cite docs/FIRMWARE-BEHAVIOUR.md by its ``fb-`` anchors and name only files that exist.

Flagged: the facts document in any form (``FIRMWARE-FACTS``, ``FACTS §n``), a bare numbered section
(``§4.2``, which names no document of the project), a path into the developers' folder (``../shared``,
``shared/...``), a ``*.md`` name no file of the repository has, a path that starts at one of the
repository's folders (or the citing file's own) and names nothing there, and an ``fb-`` anchor the
document does not declare. Not paths: URLs, patterns (``test_*.py``, ``<time>``) and paths inside other
projects (``buildhat/motor.py`` of python-build-hat starts at no folder of ours).
"""
from __future__ import annotations

import ast
import os
import pathlib
import re
from functools import lru_cache
from typing import Dict, Iterator, List, Optional, Tuple

import behaviour_doc
import pytest
from repo_paths import REPO

from buildhat_conformance.protocol.behaviour import DOC, anchors_in

PACKAGE = "buildhat_conformance"
#: The text files the package ships (setup.py's DATA patterns, the stand-in's C, the modules).
SHIPPED = (".py", ".c", ".h", ".mjs", ".md", ".json", ".jsonl", ".txt", ".script", ".html", ".css")
BINARY = (".bin", ".pem")          # shipped, but no text to cite anything in
#: Files kept byte for byte equal to a developers' original (a test compares them), so the original's
#: words stay, its provenance notes (other projects' paths, shared/spec/...) included.
VERBATIM_COPIES: Dict[str, str] = {
    "protocol/devices.json": "tests/protocol/test_devices.py keeps it equal to the original",
}
#: Files whose job is to say where the developers' material is: they may name it, and only it.
DEVELOPERS_GUIDES: Dict[str, str] = {
    "docs/DEVELOPING.md": "the developers' rules: the facts and ../shared are their sources of truth",
}
#: Citations still to convert (none: a new one fails here).
EXEMPT: Dict[str, str] = {}

FACTS = re.compile(r"FIRMWARE-FACTS|\bFACTS\b(?!-)")     # not tests/FACTS-COVERAGE.md, a file of ours
SECTION = re.compile(r"§\s*\d+(?:\.\d+)*")
SHARED = re.compile(r"\.\./shared\b|(?<![\w-])shared/(?=[\w*.-])")
URL = re.compile(r"\b[a-z][a-z0-9+.-]*://\S+")
MD_NAME = re.compile(r"(?<![\w.-])((?:\.\./|[\w.-]+/)*[\w-][\w.-]*\.md)\b")
PATH = re.compile(r"(?<![\w./-])((?:\.\./)*[\w-][\w.-]*/[\w./-]*\w\.(?:" +
                  "|".join(s.lstrip(".") for s in SHIPPED + (".toml", ".yml", ".cfg")) + r"))\b")
GENERATED = re.compile(r"(?:\.\./)*reports/")         # what a run writes, not a file of the repository
BROKEN = re.compile(r"([\w./-]*\w-)$")
COMMENT_LEAD = re.compile(r"^\s*(?:#:?|//|\*)?\s*")


def _setup_list(name: str) -> List[str]:
    tree = ast.parse((REPO / "setup.py").read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == name for t in node.targets):
            return list(ast.literal_eval(node.value))
    raise AssertionError(f"setup.py has no {name} list")


def package_tops() -> List[str]:
    return [PACKAGE, *_setup_list("FOLDERS")]


def cited_files() -> List[pathlib.Path]:
    """Every text file the package ships, docs/*.md, and the README of every folder."""
    found = set((REPO / "docs").glob("*.md"))
    for top in package_tops():
        for path in (REPO / top).rglob("*"):
            if path.is_file() and path.suffix in SHIPPED and "__pycache__" not in path.parts:
                found.add(path)
    found |= {p for p in REPO.glob("*/README.md") if p.parent.name not in ("tests", "reports")}
    return sorted(found)


@lru_cache(maxsize=1)
def _md_names() -> frozenset:
    """The name of every Markdown file of the checkout (not what a run or an install put there)."""
    names = set()
    for _here, dirs, files in os.walk(REPO):
        dirs[:] = [d for d in dirs if not d.startswith(".") and d not in ("reports", "__pycache__")]
        names |= {f for f in files if f.endswith(".md")}
    return frozenset(names)


def _exists(token: str, cited_in: pathlib.Path) -> Optional[bool]:
    """Whether ``token`` names a file or folder of the repository; None if it is no path of ours."""
    token = token.rstrip(".")
    if "/" not in token:
        return token in _md_names()
    first, name = token.split("/")[0], pathlib.PurePath(token).name
    here = [d for d in cited_in.parents if d.is_relative_to(REPO)]     # its folder, up to the root
    if first == "..":
        return (cited_in.parent / token).exists()
    if first in _tops() or any((d / first).is_dir() for d in here):
        return any((d / token).exists() for d in here)
    return name in _md_names() if token.endswith(".md") else None


@lru_cache(maxsize=1)
def _tops() -> frozenset:
    return frozenset(p.name for p in REPO.iterdir() if p.is_dir())


def lines(text: str) -> Iterator[Tuple[int, str]]:
    """(number, text) of each line, URLs blanked out; a word broken at a hyphen at the end of a line
    (``docs/FIRMWARE-`` / ``BEHAVIOUR.md#fb-errors``) is read whole on the line where it ends."""
    carry = ""
    for n, line in enumerate(text.splitlines(), 1):
        body = COMMENT_LEAD.sub("", line) if carry else line
        yield n, URL.sub(" ", carry + body)
        broken = BROKEN.search(line)
        carry = broken.group(1) if broken else ""


def _names_of_ours(plain: str) -> Iterator[str]:
    found = {m.group(1) for pattern in (MD_NAME, PATH) for m in pattern.finditer(plain)}
    for token in sorted(found):
        if not (SHARED.search(token) or GENERATED.match(token) or "*" in token or "<" in token):
            yield token


def problems(text: str, where: str, cited_in: pathlib.Path) -> Iterator[str]:
    """One line per citation of something the repository does not hold."""
    copy, guide = where in VERBATIM_COPIES, where in DEVELOPERS_GUIDES
    for n, plain in lines(text):
        at = f"{where}:{n}"
        if not guide:
            for m in FACTS.finditer(plain):
                yield f"{at}: cites the facts document ({m.group(0)!r}): cite a FIRMWARE-BEHAVIOUR.md anchor"
            for m in SECTION.finditer(plain):
                yield f"{at}: a numbered section ({m.group(0)!r}) of no named document: cite an fb- anchor"
        if copy:
            continue
        if not guide:
            for m in SHARED.finditer(plain):
                yield f"{at}: names the developers' folder ({m.group(0)!r}), which users do not have"
        for token in _names_of_ours(plain):
            if _exists(token, cited_in) is False:
                yield f"{at}: names {token}, which the repository does not contain"
        for anchor in anchors_in(plain):
            if anchor not in _declared():
                yield f"{at}: {anchor} is not an anchor of {DOC}"


@lru_cache(maxsize=1)
def _declared() -> frozenset:
    return frozenset(behaviour_doc.anchors(behaviour_doc.text()))


def _report() -> List[str]:
    found: List[str] = []
    for path in cited_files():
        where = str(path.relative_to(REPO))
        if where in EXEMPT:
            continue
        found += problems(path.read_text(encoding="utf-8", errors="replace"), where, path)
    return found


def test_the_scan_covers_the_package_docs_and_readmes():
    files = {str(p.relative_to(REPO)) for p in cited_files()}
    assert {"emulator/hat.py", "docs/USING.md", "sil/README.md", "protocol/devices.json",
            "rp2040/runner.mjs", "buildhat_conformance/cli.py"} <= files
    assert any(f.startswith("sil/standin/") and f.endswith(".c") for f in files)
    assert any(f.startswith("transcripts/") and f.endswith(".script") for f in files)
    # every kind of file setup.py ships is read (a new kind must be added to SHIPPED or BINARY)
    for pattern in _setup_list("DATA") + _setup_list("STANDIN"):
        assert pattern.endswith(SHIPPED + BINARY), pattern
    assert set(VERBATIM_COPIES) | set(DEVELOPERS_GUIDES) <= files


def test_nothing_cites_a_file_the_repository_does_not_contain():
    found = _report()
    assert not found, f"{len(found)} citation(s) of what users do not have:\n" + "\n".join(found)


# -- the checker itself: it must find what is planted, and leave what is fine -------------------------
# A planted anchor is written ``{fb}name`` so that no scan of this file (tests/protocol/test_behaviour.py
# reads the tests too) takes it for a real citation.

def _planted(text: str) -> str:
    return text.replace("{fb}", "fb-")


@pytest.mark.parametrize("planted", [
    "# the 10 ms tick (FIRMWARE-FACTS §7.1)",
    '"""Rings of 8192 bytes (FACTS §1)."""',
    "the facts (see FIRMWARE-FACTS.md) say so",
    "# the port reset (§4.2)",
    "#: one more, continuing a list: (§6.1, §6.2)",
    "the tree beside the checkout (``../shared/firmware/``)",
    "a copy of shared/protocol/devices.json",
    "see docs/NO-SUCH-DOC.md for the rest",
    "as HOWTO-NOWHERE.md explains",
    "the runner (emulator/no_such_module.py) does it",
    "(FIRMWARE-BEHAVIOUR.md#{fb}no-such-anchor)",
    "(docs/FIRMWARE-BEHAVIOUR.md#{fb}lin)",
    "# the port reset (#{fb}port-rest)",
])
def test_a_planted_citation_is_found(planted):
    cited_in = REPO / "emulator" / "planted.py"
    text = f"first line\n{_planted(planted)}\nlast line\n"
    found = list(problems(text, "emulator/planted.py", cited_in))
    assert len(found) >= 1 and all(f.startswith("emulator/planted.py:2: ") for f in found), found


@pytest.mark.parametrize("fine", [
    "# the line (FIRMWARE-BEHAVIOUR.md#fb-line, #fb-tx-ring)",
    "see docs/FIRMWARE-BEHAVIOUR.md#fb-pid and docs/USING.md",
    "the document (protocol/FIRMWARE-BEHAVIOUR.md) ships with the package",
    "https://github.com/RaspberryPiFoundation/python-build-hat/blob/main/buildhat/motors.py, its README.md",
    "the module emulator/ports/port.py and ../docs/LAB.md",
    "python-build-hat's buildhat/motors.py sends it",
    "every test_*.py of cases/; reports/runs/<time>/junit.xml",
    "BUILDHAT_SHARED=DIR, the buildhat_emulator_shared fixture",
    "the facts give every release (the project's account of them)",
])
def test_a_fine_citation_is_left_alone(fine):
    cited_in = REPO / "emulator" / "planted.py"
    assert list(problems(fine, "emulator/planted.py", cited_in)) == []


def test_a_name_broken_at_a_hyphen_is_read_whole():
    cited_in = REPO / "conformance" / "planted.py"
    whole = '    """e.g. ``"Error (docs/FIRMWARE-\n    BEHAVIOUR.md#fb-errors)"``.\n'
    assert list(problems(whole, "conformance/planted.py", cited_in)) == []
    wrong = "# as docs/FIRMWARE-\n# BEHAVIOUR.md#{fb}nope says, and docs/NOT-\n# THERE.md\n"
    assert [f.split(": ", 1)[0] for f in problems(_planted(wrong), "conformance/planted.py", cited_in)] == \
        ["conformance/planted.py:2", "conformance/planted.py:3"]


def test_a_verbatim_copy_and_the_developers_guide_keep_their_words():
    path = REPO / "protocol" / "devices.json"
    assert not list(problems("same text as shared/spec/x.txt (joniumGit/buildhat docs/protocol.md)",
                             "protocol/devices.json", path))
    guide = REPO / "docs" / "DEVELOPING.md"
    assert not list(problems("`../shared/protocol/FIRMWARE-FACTS.md`, §4.1 `fb-commands`",
                             "docs/DEVELOPING.md", guide))
    # but the guide, too, names only documents that exist and anchors the document declares
    gone = _planted("see docs/GONE.md and FIRMWARE-BEHAVIOUR.md#{fb}gone")
    assert len(list(problems(gone, "docs/DEVELOPING.md", guide))) == 2
