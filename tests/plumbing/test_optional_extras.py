"""The install hint for an optional extra (plumbing/optional_extras.py) names its packages as pyproject.toml
declares
them, and the editable install for a checkout."""
from __future__ import annotations


def test_extra_hint_names_the_extras_packages():
    from buildhat_conformance.plumbing.optional_extras import install_hint

    hint = install_hint("plots")
    assert hint.startswith("pip install 'matplotlib>=") and "pip install -e '.[plots]'" in hint
    assert "pytest-xdist" in install_hint("parallel")
