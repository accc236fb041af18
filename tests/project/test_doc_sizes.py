"""The two pages a newcomer reads first stay short (issue #36): the README is the user's page (at most
200 lines); docs/ARCHITECTURE.md is one page (at most 70 lines of at most 120 characters)."""
from __future__ import annotations

from pathlib import Path
from typing import List

from repo_paths import REPO


def too_long(path: Path, max_lines: int, max_width: int) -> List[str]:
    lines = path.read_text(encoding="utf-8").splitlines()
    problems = [f"{path.name}: {len(lines)} lines (at most {max_lines})"] if len(lines) > max_lines else []
    problems += [f"{path.name}:{n}: {len(line)} characters (at most {max_width})"
                 for n, line in enumerate(lines, 1) if len(line) > max_width]
    return problems


def test_the_readme_is_one_page_for_the_user() -> None:
    assert not too_long(REPO / "README.md", 200, 10_000)


def test_the_architecture_is_one_page() -> None:
    assert not too_long(REPO / "docs" / "ARCHITECTURE.md", 70, 120)


def test_the_check_counts_lines_and_characters(tmp_path: Path) -> None:
    page = tmp_path / "PAGE.md"
    page.write_text("a\n" * 3 + "b" * 11 + "\n", encoding="utf-8")
    assert too_long(page, 4, 11) == []
    assert too_long(page, 3, 10) == ["PAGE.md: 4 lines (at most 3)", "PAGE.md:4: 11 characters (at most 10)"]
