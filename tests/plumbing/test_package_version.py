"""The package's version (plumbing/package_version.py) is the one pyproject.toml declares (its one source)."""
from __future__ import annotations

import re

from repo_paths import REPO

from buildhat_conformance.plumbing.package_version import __version__


def test_the_version_is_pyprojects():
    pyproject = (REPO / "pyproject.toml").read_text(encoding="utf-8")
    declared = re.search(r'^version = "([^"]+)"$', pyproject, re.M)
    assert declared is not None and __version__ == declared.group(1)
