"""Imports the suite's test modules by their package name.

pytest names a test module after its file path; in an editable checkout that is
``conformance.cases.test_list`` rather than ``buildhat_conformance.conformance.cases.test_list``, and the
suite's relative imports (``from ..protocol import ...``) only work under the package name.
"""
from __future__ import annotations

import importlib
from pathlib import Path
from types import ModuleType
from typing import Any, Optional

import pytest

from .. import cases

SUITE_DIR = Path(cases.__file__).resolve().parent


class SuiteModule(pytest.Module):
    """A test module of the suite, imported as ``<package>.<stem>``."""

    def _getobj(self) -> ModuleType:
        return importlib.import_module(f"{cases.__name__}.{self.path.stem}")


@pytest.hookimpl(tryfirst=True)
def pytest_pycollect_makemodule(module_path: Path, parent: Any) -> Optional[pytest.Module]:
    if module_path.resolve().parent == SUITE_DIR and module_path.name.startswith("test_"):
        return SuiteModule.from_parent(parent, path=module_path)
    return None
