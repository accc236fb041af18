"""A JUnit XML file that is complete and valid after every test case.

Per case the ``verdict`` property carries one of conformance/verdict.py's VERDICTS; the suite's
``verdict_count.<verdict>`` properties count them (a target fault is a JUnit ``<error>``, a case
not run a ``<skipped>``, but neither is a protocol failure).

pytest's own ``--junitxml`` is written once, at the end; a run whose target dies (or whose
process is killed) would leave nothing. This writer rewrites the whole file atomically
after each case that did not pass, and after a passing one when the last write is
``REWRITE_EVERY_S`` old (a whole rewrite per case was a tenth of a virtual-time run): the file on
disk is always a valid report of everything run up to a moment ago, every failure included,
and complete once the session ends (SIGTERM and Ctrl-C included; the transcripts keep every byte).
"""
from __future__ import annotations

import os
import re
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Any, List, Optional, Sequence, Tuple

from ..target_fault import first_line

__all__ = ["Case", "JUnitFile", "REWRITE_EVERY_S", "failure_line"]

REWRITE_EVERY_S = 0.2


@dataclass
class Case:
    classname: str
    name: str
    time: float = 0.0
    outcome: str = "passed"            # passed / failed / error / skipped
    message: str = ""
    details: str = ""
    properties: List[Tuple[str, str]] = field(default_factory=list)


_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f]")


def _clean(text: str) -> str:
    # XML 1.0 cannot carry most control characters; HAT output may contain any byte.
    # A regex, not a loop over characters: the whole file is rewritten after every case, and
    # the per-character loop made that the run's biggest cost after the waits (H10 profile).
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", str(text))


class JUnitFile:
    def __init__(self, path: str, suite: str, properties: Sequence[Tuple[str, str]] = ()):
        self.path = path
        self.suite = suite
        self.properties = list(properties)
        self.cases: List[Case] = []
        self._xml_cache: dict = {}
        self._written_at = 0.0
        self.write()

    def set_property(self, name: str, value: str) -> None:
        self.properties = [(n, v) for n, v in self.properties if n != name] + [(name, value)]

    def add(self, case: Case) -> None:
        self.cases.append(case)
        if case.outcome != "passed" or time.monotonic() - self._written_at >= REWRITE_EVERY_S:
            self.write()

    def _suite(self) -> ET.Element:
        count = {k: sum(1 for c in self.cases if c.outcome == k) for k in ("failed", "error", "skipped")}
        suite = ET.Element("testsuite", name=self.suite, tests=str(len(self.cases)),
                           failures=str(count["failed"]), errors=str(count["error"]),
                           skipped=str(count["skipped"]),
                           time=f"{sum(c.time for c in self.cases):.3f}")
        props = ET.SubElement(suite, "properties")
        for name, value in self.properties + self._verdict_counts():
            ET.SubElement(props, "property", name=_clean(name), value=_clean(value))
        return suite

    def _verdict_counts(self) -> List[Tuple[str, str]]:
        """``verdict_count.<verdict>`` for every verdict the cases carry (their ``verdict``
        property): target faults and cases not run have their own count, apart from failures."""
        counts: dict = {}
        for c in self.cases:
            v = dict(c.properties).get("verdict")
            if v:
                counts[v] = counts.get(v, 0) + 1
        return [(f"verdict_count.{v}", str(n)) for v, n in sorted(counts.items())]

    @staticmethod
    def _case_element(c: Case) -> ET.Element:
        tc = ET.Element("testcase", classname=_clean(c.classname), name=_clean(c.name), time=f"{c.time:.3f}")
        if c.properties:
            props = ET.SubElement(tc, "properties")
            for name, value in c.properties:
                ET.SubElement(props, "property", name=_clean(name), value=_clean(value))
        tag = {"failed": "failure", "error": "error", "skipped": "skipped"}.get(c.outcome)
        if tag:
            el = ET.SubElement(tc, tag, message=_clean(c.message[:500]))
            el.text = _clean(c.details)
        return tc

    def _tree(self) -> ET.Element:
        root = ET.Element("testsuites")
        suite = self._suite()
        root.append(suite)
        for c in self.cases:
            suite.append(self._case_element(c))
        return root

    def _case_xml(self, c: Case) -> str:
        # Each case is serialised once (H10: re-serialising every case after every case made
        # a full run's report writing quadratic, seconds of a one-minute run). A Case is not
        # changed once added, so its text is cached by identity.
        key = id(c)
        cached = self._xml_cache.get(key)
        if cached is None or cached[0] is not c:
            cached = (c, ET.tostring(self._case_element(c), encoding="unicode"))
            self._xml_cache[key] = cached
        return cached[1]

    def write(self, path: Optional[str] = None) -> None:
        path = path or self.path
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        tmp = f"{path}.tmp{os.getpid()}"
        suite = self._suite()
        ET.SubElement(suite, "CASES")
        text = ET.tostring(suite, encoding="unicode").replace(
            "<CASES />", "".join(self._case_xml(c) for c in self.cases), 1)
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("<?xml version='1.0' encoding='utf-8'?>\n<testsuites>" + text + "</testsuites>")
        os.replace(tmp, path)
        self._written_at = time.monotonic()


def failure_line(report: Any) -> str:
    """One line saying what failed: the exception's own message (pytest's "crash" line), never
    the first line of the traceback (that is `hat = <...Hat object at 0x...>`)."""
    crash = getattr(getattr(report, "longrepr", None), "reprcrash", None)
    message = getattr(crash, "message", "") if crash is not None else ""
    line = first_line(message) if message else first_line(report.longreprtext)
    for prefix in ("Failed: ", "AssertionError: "):
        line = line.removeprefix(prefix)
    return line
