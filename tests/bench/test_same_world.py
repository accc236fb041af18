"""The same-world figure (bench/same_world.py), in small: one script on the firmware in the loop and
on the emulator; the figure counts the comparison's own lines. No timing is asserted."""
from __future__ import annotations

import pytest
from sil_support import firmware_tree

from buildhat_conformance.bench import same_world

pytestmark = pytest.mark.timeout(600)


def test_the_figure_counts_the_compared_lines(monkeypatch):
    monkeypatch.setenv("BUILDHAT_FIRMWARE_TREE", str(firmware_tree()))
    (path,) = [p for p in same_world.scripts() if p.name == "separators.script"]
    got = same_world.measure([path])
    # the script's 31 answer lines (echo off: one line per answer or its CRLF), all equal and in time
    assert got["lines"] == 31, got
    assert got["equal_pct"] == 100.0 and got["within_1ms_pct"] == 100.0, got
    assert got["note"].startswith("31 lines in 1 scripts")
