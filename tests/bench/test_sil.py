"""The firmware-in-the-loop figures (bench/sil.py), in small: the suite's `version` cases on the real
firmware, counted from the run's own JUnit file. No timing is asserted."""
from __future__ import annotations

import pytest
from sil_support import firmware_tree

from buildhat_conformance.bench import sil

pytestmark = pytest.mark.timeout(600)


def test_the_suite_on_the_firmware_is_counted_from_its_junit(tmp_path, monkeypatch):
    monkeypatch.setenv("BUILDHAT_FIRMWARE_TREE", str(firmware_tree()))
    monkeypatch.setenv("BUILDHAT_SIL_CACHE", str(tmp_path / "cache"))
    got = sil.suite(real_time=False, keyword="version")
    assert got["cases"] > 0 and got["failed"] == 0, got
    assert got["note"].startswith(f"{got['cases']} cases, 0 failed or faulted")
    assert got["note"].endswith("(-k version)")
