"""The one way tests reach ``../shared`` (the developers' originals: the facts document, the
formats, devices.json, the firmware's source tree), and how they skip without it.

A user's clone has no ``../shared``; ``BUILDHAT_SHARED`` points elsewhere (``BUILDHAT_SHARED=/nonexistent
make test`` is such a clone). Every skip this module raises starts with :data:`SKIP_PREFIX`, so the
closing summary (tests/conftest.py) can count them and say why they skipped.
"""
from __future__ import annotations

import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
ENV = "BUILDHAT_SHARED"
SKIP_PREFIX = "no ../shared"
#: The project's own account of the facts: what tests read when the data is the project's.
BEHAVIOUR_DOC = REPO / "docs" / "FIRMWARE-BEHAVIOUR.md"


def shared_root() -> pathlib.Path:
    """``$BUILDHAT_SHARED`` if set, else ``shared/`` beside the checkout."""
    return pathlib.Path(os.environ.get(ENV) or REPO.parent / "shared")


def need_shared(*parts: str, what: str) -> pathlib.Path:
    """``shared/<parts>``, or skip the test saying ``what`` it needed it for."""
    path = shared_root().joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{SKIP_PREFIX} ({what}): {path} not found; set {ENV} to the shared folder")
    return path


def facts_text() -> str:
    """The original facts document, for the tests that check the project's account against it."""
    path = need_shared("protocol", "FIRMWARE-FACTS.md", what="the facts document itself")
    return path.read_text(encoding="utf-8")
