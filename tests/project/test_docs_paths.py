"""Every path named in docs/*.md and in each folder's README exists: docs that drift from the
code fail here, not in a reader's hands.

A path is a Markdown link (relative to the document), or a `code span` that starts with one of the
repository's own folders (``harness/session.py``, ``conformance/cases/``) or, in a folder's README,
names a module of that folder or starts with one of its sub-folders (``plugin/run.py``,
``oracles/``). Generated places (``reports/``), patterns (``test_*.py``, ``<time>``) and paths
outside the repository (``../shared/...``) are not paths here.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Iterator, List, Optional, Tuple

import pytest
from repo_paths import REPO

TOPS = ("protocol", "harness", "transcripts", "emulator", "sil", "conformance", "fuzz", "bench",
        "buildhat_conformance", "docs", "tests", "examples")
SPAN = re.compile(r"`([^`\n]+)`")
LINK = re.compile(r"\]\(([^)\s#]+)(?:#[^)]*)?\)")
FILE = re.compile(r"^[\w./-]+$")
NOT_A_PATH = ("<", "*", "{", "$", "...", "://")


def documents() -> List[Path]:
    readmes = [p for top in TOPS for p in (REPO / top).rglob("README.md")
               if "__pycache__" not in p.parts and not p.is_relative_to(REPO / "tests")]
    return sorted(set((REPO / "docs").glob("*.md")) | set(readmes))


def candidates(text: str) -> Iterator[Tuple[str, bool]]:
    """(token, whether it is a link) of every code span and Markdown link."""
    for m in SPAN.finditer(text):
        yield m.group(1).strip(), False
    for m in LINK.finditer(text):
        yield m.group(1).strip(), True


def as_path(token: str, doc: Path, link: bool = False) -> Optional[Path]:
    """Where ``token`` points, or None if it names no file of the repository."""
    if link:
        if "://" in token or token.startswith("mailto:"):
            return None
        target = (doc.parent / token).resolve()
        return target if target.is_relative_to(REPO) else None
    token = token.split("::")[0].split(":")[0].rstrip(".,;)")
    if not token or any(s in token for s in NOT_A_PATH) or not FILE.match(token) or \
            token.startswith(("./", "reports/")):
        return None
    if token.startswith("../"):
        if doc.parent == REPO / "docs" or token.lstrip("./").startswith("shared/"):
            return None          # docs/*.md name the sibling of the checkout (../shared/) this way
        target = (doc.parent / token).resolve()
        return target if target.is_relative_to(REPO) else None
    first = token.split("/")[0]
    if "/" in token and first in TOPS:
        return REPO / token
    if doc.parent != REPO / "docs" and (token.endswith((".py", ".json", ".md")) or
                                         ("/" in token and (doc.parent / first).is_dir())):
        return doc.parent / token                            # a folder README names its own files
    return None


@pytest.mark.parametrize("doc", documents(), ids=lambda p: str(p.relative_to(REPO)))
def test_every_path_a_document_names_exists(doc: Path):
    missing = sorted({token for token, link in candidates(doc.read_text(encoding="utf-8"))
                      for path in [as_path(token, doc, link)] if path is not None and not path.exists()})
    assert not missing, f"{doc.relative_to(REPO)} names paths that do not exist: {missing}"


def test_the_reader_finds_paths_and_leaves_the_rest(tmp_path):
    # Guards the reader: one that found nothing would pass every document.
    doc = REPO / "conformance" / "README.md"
    assert as_path("harness/session.py", doc) == REPO / "harness" / "session.py"
    assert as_path("plugin/run.py", doc) == REPO / "conformance" / "plugin" / "run.py"
    assert as_path("no_such_module.py", doc) == REPO / "conformance" / "no_such_module.py"
    assert as_path("oracles/gone.py", doc) == REPO / "conformance" / "oracles" / "gone.py"
    assert as_path("../docs/LAB.md", doc, link=True) == REPO / "docs" / "LAB.md"
    assert as_path("../docs/LAB.md", doc) == REPO / "docs" / "LAB.md"
    for not_a_path in ("reports/runs/<time>/", "test_*.py", "pytest conformance/cases", "socket://HOST:PORT",
                       "firmware-pico/"):
        assert as_path(not_a_path, doc) is None
    assert as_path("../shared/spec/", REPO / "docs" / "DEVELOPING.md") is None
    assert list(candidates("see `harness/gone.py` and [x](../docs/NOPE.md#a)")) == \
        [("harness/gone.py", False), ("../docs/NOPE.md", True)]
