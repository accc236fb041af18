"""Every check of the suite's cases says what failed in the suite's words (issue #34): an ``assert``
in conformance/cases/ or conformance/oracles/ carries its own message, or the case compares through
conformance/mismatch.py. The suite's child pytest runs with ``--assert=plain``, so a bare assert
would fail with no message at all (and, rewritten, with pytest's "Use -v to get more diff")."""
from __future__ import annotations

import ast
from typing import List

from repo_paths import REPO

FOLDERS = ("conformance/cases", "conformance/oracles")


def bare_asserts() -> List[str]:
    found = []
    for folder in FOLDERS:
        for path in sorted((REPO / folder).rglob("*.py")):
            source = path.read_text(encoding="utf-8")
            for node in ast.walk(ast.parse(source)):
                if isinstance(node, ast.Assert) and node.msg is None:
                    where = f"{path.relative_to(REPO)}:{node.lineno}"
                    found.append(f"{where}: {ast.get_source_segment(source, node)}")
    return found


def test_every_assert_of_the_cases_has_a_message() -> None:
    missing = bare_asserts()
    assert not missing, "asserts with no message of their own (use conformance/mismatch.py's same, " \
                        "rejected, accepted, or say what was sent, expected and came):\n" + "\n".join(missing)


def test_the_suite_runs_without_pytests_assertion_rewriting() -> None:
    import argparse

    from buildhat_conformance.conformance.runner import pytest_argv
    args = argparse.Namespace(junit="reports/junit.xml", transcripts=None, target="inprocess", extra=[],
                              firmware=None, keyword=None, operator=False)
    assert "--assert=plain" in pytest_argv(args)
