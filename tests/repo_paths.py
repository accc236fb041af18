"""Where the tests and the checkout are, for tests in any sub-folder of tests/ (their own
``__file__`` says only how deep they sit)."""
from __future__ import annotations

import ast
import pathlib
from typing import List

TESTS = pathlib.Path(__file__).resolve().parent
REPO = TESTS.parent
PACKAGE = "buildhat_conformance"


def package_folders(repo: pathlib.Path) -> List[str]:
    """The top-level folders setup.py installs under the package (its ``FOLDERS``), and the root."""
    tree = ast.parse((repo / "setup.py").read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "FOLDERS" for t in node.targets):
            return [PACKAGE, *ast.literal_eval(node.value)]
    raise AssertionError("setup.py has no FOLDERS list")
