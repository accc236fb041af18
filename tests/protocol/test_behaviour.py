"""docs/FIRMWARE-BEHAVIOUR.md is the facts a user can read: every anchor the project cites exists
in it, nothing a user reads points at FIRMWARE-FACTS (a file users do not have), and, where
``../shared`` exists, its exact strings are the original facts' strings."""
from __future__ import annotations

import ast
import json
import pathlib
import re
from typing import Iterator, List, Tuple

import behaviour_doc
import pytest
from repo_paths import REPO
from shared_material import BEHAVIOUR_DOC, facts_text

from buildhat_conformance.conformance.deviations import deviations
from buildhat_conformance.protocol.behaviour import ANCHOR, DOC, anchors_in, cite, section_text

PACKAGE_TOPS = ("protocol", "harness", "emulator", "conformance", "fuzz", "bench", "buildhat_conformance",
                "transcripts")
TEXT_SUFFIXES = (".py", ".md", ".json", ".jsonl", ".script", ".html", ".txt", ".toml", ".yml")
# Verbatim copies of ../shared/formats (tests/project/test_packaging.py keeps them word for word), and the
# developers' rules, which name the original facts the document is written from.
NOT_USER_FACING = {REPO / "docs" / "DEVELOPING.md"} | set((REPO / "docs" / "formats").glob("*.md"))
CITES_FACTS = re.compile(r"FIRMWARE-FACTS|\bFACTS\s*§|shared/protocol")


def _files(tops) -> Iterator[pathlib.Path]:
    for top in tops:
        for path in sorted((REPO / top).rglob("*")):
            if path.is_file() and path.suffix in TEXT_SUFFIXES and "__pycache__" not in path.parts:
                yield path


def _everything() -> List[pathlib.Path]:
    """The package, the docs, the golden transcripts, the examples, the top-level files, the tests."""
    return list(_files(PACKAGE_TOPS + ("docs", "examples", "tests"))) \
        + [REPO / "README.md", REPO / "Makefile", REPO / "pyproject.toml"]


def test_the_document_declares_each_anchor_once_and_cites_only_its_own():
    doc = behaviour_doc.text()
    declared = behaviour_doc.anchors(doc)
    assert len(declared) > 100 and len(declared) == len(set(declared)), \
        sorted(a for a in declared if declared.count(a) > 1)
    assert all(ANCHOR.fullmatch(a) for a in declared)
    links = set(re.findall(r"\]\(#(fb-[a-z0-9-]+)\)", doc))
    assert links and links <= set(declared), sorted(links - set(declared))


def test_every_cited_anchor_exists_in_the_document():
    declared = set(behaviour_doc.anchors(behaviour_doc.text()))
    missing: List[Tuple[str, str]] = []
    cited = 0
    for path in _everything():
        if path in (BEHAVIOUR_DOC, pathlib.Path(__file__).resolve()):
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            for anchor in anchors_in(line):
                cited += 1
                if anchor not in declared:
                    missing.append((f"{path.relative_to(REPO)}:{n}", anchor))
    assert cited > 50, "the scan found (almost) no citations: is the anchor pattern right?"
    assert not missing, "\n".join(f"{where}: {a} is not in {DOC}" for where, a in missing)


def test_every_known_deviation_names_sections_that_exist():
    declared = set(behaviour_doc.anchors(behaviour_doc.text()))
    raw = json.loads((REPO / "conformance" / "deviations.json").read_text(encoding="utf-8"))
    for key, d in raw["deviations"].items():
        assert "facts" not in d, f"{key}: the old FIRMWARE-FACTS section field"
        assert d["behaviour"] and set(d["behaviour"]) <= declared, (key, d["behaviour"])
    # what the report and the JUnit messages print for them
    assert deviations()["BIAS-REMOVED"].reference == cite(raw["deviations"]["BIAS-REMOVED"]["behaviour"])
    assert cite(["fb-pwm", "fb-on-off"]) == f"{DOC}#fb-pwm, #fb-on-off" and cite([]) == DOC


def test_the_package_carries_the_document_and_quotes_whole_sections():
    """protocol/FIRMWARE-BEHAVIOUR.md (installed as package data) is the document itself, and a cited
    section is quoted whole: an inline anchor gives its list item, a line anchor its part."""
    assert (REPO / "protocol" / "FIRMWARE-BEHAVIOUR.md").read_text(encoding="utf-8") == behaviour_doc.text()
    on_off = section_text("fb-on-off")
    assert on_off.startswith("- `on` / `off`") and on_off.endswith("True of every release.")
    assert "<a id" not in on_off and "`set <x>`" not in on_off
    assert section_text("fb-r1-passive").count("\n  - ") == 3        # the nested items come along
    assert "P0: pv=0.995000" in section_text("fb-debug-pid")          # and the block under an item
    data = section_text("fb-data-lines")
    assert data.startswith("### 7.1") and "Modes 8 to 15 never report" in data and "7.2" not in data
    assert section_text("fb-no-such-section") == ""
    for d in deviations().values():
        assert all(section_text(a) for a in d.behaviour), d.key


def _user_strings(path: pathlib.Path) -> Iterator[Tuple[int, str]]:
    """The string literals of a module that can reach a user (messages, help, report text): all but
    docstrings, except a module docstring the module itself prints (``__doc__`` as --help text).
    Comments are not strings, so developers' notes may still name the facts."""
    source = path.read_text(encoding="utf-8")
    tree = ast.parse(source)
    docs = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module) and "__doc__" in source:
            continue
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                docs.add(id(first.value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            yield node.lineno, node.value


def test_nothing_a_user_reads_cites_the_facts_file():
    bad = []
    for path in _files(PACKAGE_TOPS):
        if path.suffix == ".py":
            bad += [f"{path.relative_to(REPO)}:{n}: {s[:80]!r}" for n, s in _user_strings(path)
                    if CITES_FACTS.search(s) or re.search(r"§\d", s)]
        else:   # package data: deviations.json, profiles.json, REQUIREMENTS.md, READMEs, report assets
            bad += [f"{path.relative_to(REPO)}: {m.group(0)}"
                    for m in CITES_FACTS.finditer(path.read_text(encoding="utf-8"))]
    for path in [REPO / "README.md", *(REPO / "docs").rglob("*.md"),
                 *(REPO / "transcripts" / "data").glob("*"), *(REPO / "examples").rglob("*.md")]:
        if path.is_file() and path not in NOT_USER_FACING:
            text = path.read_text(encoding="utf-8", errors="replace")
            bad += [f"{path.relative_to(REPO)}: {m.group(0)}" for m in CITES_FACTS.finditer(text)]
    assert not bad, "cite docs/FIRMWARE-BEHAVIOUR.md#fb-... instead:\n" + "\n".join(bad)


# -- against the original facts (skips in a clone without ../shared) ---------------------------

def _fenced_blocks(text: str) -> List[str]:
    return [block.strip("\n") for block in re.findall(r"```\n(.*?)```", text, re.S)]


def test_exact_strings_are_the_facts_strings():
    """Help texts, the bootloader's help, the PID and fault-dump examples, the prefix table and the
    release strings carry over from the facts byte for byte; only the prose is the project's."""
    facts, doc = facts_text(), behaviour_doc.text()
    facts_blocks = _fenced_blocks(facts)
    for anchor in ("fb-help-r6", "fb-help-r1", "fb-bootloader-commands", "fb-debug-pid",
                   "fb-motor-fault-dump"):
        block = "\n".join(behaviour_doc.code_block(doc, anchor))
        assert any(block.strip() == f.strip() or block in f for f in facts_blocks), anchor
    for line in behaviour_doc.help_lines(doc)["R5"]:
        assert line in facts
    ours = behaviour_doc.shortest_table(doc)
    theirs_sec = facts.split("**Shortest prefix that resolves to each command**", 1)[1]
    theirs_sec = theirs_sec.split("**Ambiguous", 1)[0]
    theirs = {c[0]: c[1:] for c in ([x.strip() for x in ln.strip().strip("|").split("|")]
                                    for ln in theirs_sec.splitlines()) if len(c) == 4}
    assert ours == {k: v for k, v in theirs.items() if k in ours} and len(ours) == 28
    releases = behaviour_doc.section(doc, "fb-releases")
    for version in re.findall(r"`(\d{10} \d{4}-\d\d-\d\dT[\d:+]+)`", releases):
        assert f"`{version}`" in facts
    signature = re.search(r"`(Firmware signature: [0-9A-F ]+)`", doc)
    assert signature and signature.group(1) in facts


@pytest.mark.parametrize("pattern", [
    r"R1 \d+,\s+R2 \d+,\s+R3 \d+,\s+R4 \d+,\s+R5 \d+,\s+R6 \d+,\s+R7 \d+",   # image checksums
    r"T ?= ?0\.1 → 11.*?0\.7 → 71",                                  # waveform end ticks
])
def test_numbers_are_the_facts_numbers(pattern):
    facts, doc = facts_text(), behaviour_doc.text()
    ours = re.search(pattern, doc, re.S)
    assert ours, pattern
    assert re.findall(r"\d+(?:\.\d+)?", ours.group(0)) == \
        re.findall(r"\d+(?:\.\d+)?", re.search(pattern, facts, re.S).group(0))
