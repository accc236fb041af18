"""The suite's JUnit file (conformance/plugin/junit.py) stays a valid report while the run goes: a case
that did not pass is on disk at once, passing ones at most ``REWRITE_EVERY_S`` later, and
everything once the session writes it at the end."""
from __future__ import annotations

import xml.etree.ElementTree as ET

from buildhat_conformance.conformance.plugin import junit
from buildhat_conformance.conformance.plugin.junit import Case, JUnitFile


def _names(path) -> list:
    return [c.get("name") for c in ET.parse(path).getroot().iter("testcase")]


def test_failures_at_once_passes_within_the_rewrite_period(tmp_path, monkeypatch) -> None:
    path = tmp_path / "junit.xml"
    monkeypatch.setattr(junit, "REWRITE_EVERY_S", 3600.0)    # no passing case is due on its own
    jf = JUnitFile(str(path), "suite")
    assert _names(path) == []
    jf.add(Case("c", "ok_1"))
    assert _names(path) == []                                  # not yet: a moment later at most
    jf.add(Case("c", "bad", outcome="failed", message="expected X"))
    assert _names(path) == ["ok_1", "bad"]                     # a failure is written at once
    jf.add(Case("c", "fault", outcome="error"))
    assert _names(path) == ["ok_1", "bad", "fault"]
    jf.add(Case("c", "ok_2"))
    jf.write()                                                 # the session's closing write
    assert _names(path) == ["ok_1", "bad", "fault", "ok_2"]


def test_passing_cases_are_written_once_the_period_is_over(tmp_path, monkeypatch) -> None:
    path = tmp_path / "junit.xml"
    monkeypatch.setattr(junit, "REWRITE_EVERY_S", 0.0)
    jf = JUnitFile(str(path), "suite")
    for i in range(3):
        jf.add(Case("c", f"ok_{i}"))
        assert _names(path) == [f"ok_{j}" for j in range(i + 1)]
