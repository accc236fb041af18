"""Reading the suite's JUnit XML: test cases with their verdict class and properties.

The conformance plugin writes one ``<testsuite>`` per run and, per ``<testcase>``, a
``<properties>`` block: requirement IDs, target, firmware, profile, verdict class and the
transcript path. Property names are matched loosely (``req``/``requirement(s)``...) so files
from other writers still read; a case without a ``verdict`` property gets it from the usual
JUnit children (``failure``/``error`` -> fail, ``skipped`` -> skip, none -> pass).
"""
from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

__all__ = ["Case", "JunitRun", "read_junit", "check_junit", "VERDICTS", "normalise_verdict"]

#: The verdict classes, in the order reports show them.
VERDICTS = ("pass", "fail", "target_fault", "not_run", "skip", "known_deviation", "informational")

_VERDICT_WORDS = {
    "pass": "pass", "passed": "pass", "ok": "pass", "success": "pass",
    "fail": "fail", "failed": "fail", "failure": "fail", "error": "fail", "broken": "fail",
    "skip": "skip", "skipped": "skip", "needs": "skip", "not_applicable": "skip",
    "known_deviation": "known_deviation", "deviation": "known_deviation", "xfail": "known_deviation",
    "xfailed": "known_deviation", "known": "known_deviation",
    "informational": "informational", "info": "informational", "information": "informational",
    # The target's fault (silent, dead, rebooted, garbled), never the target failing the protocol;
    # and cases a run could not get to (the target went away before them).
    "target_fault": "target_fault", "fault": "target_fault", "not_run": "not_run", "notrun": "not_run",
}

_REQ_KEYS = ("req", "reqs", "requirement", "requirements", "requirement_id", "requirement_ids", "ids")
_TRANSCRIPT_KEYS = ("transcript", "transcript_path")


def normalise_verdict(text: str) -> Optional[str]:
    """One of VERDICTS for the spellings writers use (``known deviation``, ``XFAIL``...)."""
    key = re.sub(r"[\s\-]+", "_", text.strip().lower())
    return _VERDICT_WORDS.get(key)


@dataclass
class Case:
    classname: str
    name: str
    time: float
    verdict: str
    outcome: str                   # what the JUnit children say: pass | fail | error | skip
    message: str = ""
    detail: str = ""
    requirements: Tuple[str, ...] = ()
    properties: Dict[str, List[str]] = field(default_factory=dict)
    transcript: Optional[str] = None   # absolute when the file exists relative to the JUnit file

    @property
    def test_id(self) -> str:
        return f"{self.classname}::{self.name}" if self.classname else self.name

    def prop(self, key: str, default: str = "") -> str:
        vals = self.properties.get(key)
        return vals[0] if vals else default


@dataclass
class JunitRun:
    """One JUnit file: one run of the suite against one target."""

    path: str
    suite_name: str
    cases: List[Case]
    attributes: Dict[str, str]
    properties: Dict[str, List[str]]
    problems: List[str]

    def _common(self, key: str) -> str:
        vals = self.properties.get(key) or []
        if vals:
            return vals[0]
        seen = Counter(c.prop(key) for c in self.cases if c.prop(key))
        return seen.most_common(1)[0][0] if seen else ""

    @property
    def target(self) -> str:
        return self._common("target")

    @property
    def firmware(self) -> str:
        return self._common("firmware")

    @property
    def profile(self) -> str:
        return self._common("profile")

    @property
    def label(self) -> str:
        bits = [b for b in (self.target, self.profile or self.firmware) if b]
        return " / ".join(bits) if bits else os.path.basename(self.path)

    def counts(self) -> Dict[str, int]:
        c = Counter(case.verdict for case in self.cases)
        return {v: c.get(v, 0) for v in VERDICTS}


def _properties(elem: Optional[ET.Element]) -> Dict[str, List[str]]:
    out: Dict[str, List[str]] = {}
    if elem is None:
        return out
    for p in elem.findall("property"):
        name = (p.get("name") or "").strip()
        value = p.get("value")
        if value is None:
            value = (p.text or "").strip()
        if name:
            out.setdefault(name.lower(), []).append(value)
    return out


def _case(elem: ET.Element, base_dir: str) -> Case:
    props = _properties(elem.find("properties"))
    outcome, message, detail = "pass", "", ""
    for tag, kind in (("failure", "fail"), ("error", "error"), ("skipped", "skip")):
        child = elem.find(tag)
        if child is not None:
            outcome = kind
            message = child.get("message") or ""
            detail = (child.text or "").strip()
            break
    verdict = None
    for key in ("verdict", "verdict_class", "result"):
        if props.get(key):
            verdict = normalise_verdict(props[key][0])
            break
    if verdict is None:
        verdict = {"pass": "pass", "fail": "fail", "error": "fail", "skip": "skip"}[outcome]
    reqs: List[str] = []
    for key in _REQ_KEYS:
        for value in props.get(key, []):
            reqs.extend(x for x in re.split(r"[,\s]+", value) if x)
    transcript = None
    for key in _TRANSCRIPT_KEYS:
        if props.get(key):
            transcript = props[key][0]
            cand = transcript if os.path.isabs(transcript) else os.path.join(base_dir, transcript)
            if not os.path.exists(cand) and os.path.exists(transcript):
                cand = os.path.abspath(transcript)   # written relative to the working directory
            transcript = cand
            break
    try:
        t = float(elem.get("time") or 0.0)
    except ValueError:
        t = 0.0
    return Case(classname=elem.get("classname") or "", name=elem.get("name") or "", time=t,
                verdict=verdict, outcome=outcome, message=message, detail=detail,
                requirements=tuple(dict.fromkeys(reqs)), properties=props, transcript=transcript)


def read_junit(path: str) -> JunitRun:
    """Every test case of a JUnit file (all its testsuite elements), plus any problems
    :func:`check_junit` finds."""
    tree = ET.parse(path)
    root = tree.getroot()
    suites = [root] if root.tag == "testsuite" else root.findall("testsuite")
    base_dir = os.path.dirname(os.path.abspath(path))
    cases: List[Case] = []
    for suite in suites:
        cases.extend(_case(tc, base_dir) for tc in suite.iter("testcase"))
    first = suites[0] if suites else root
    return JunitRun(path=path, suite_name=first.get("name") or "", cases=cases, attributes=dict(first.attrib),
               properties=_properties(first.find("properties")), problems=check_junit_tree(root))


def check_junit(path: str) -> List[str]:
    """What common CI readers (Jenkins, GitLab, GitHub actions) would trip over; [] if none."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        return [f"not well-formed XML: {exc}"]
    return check_junit_tree(root)


def check_junit_tree(root: ET.Element) -> List[str]:
    problems: List[str] = []
    if root.tag == "testsuites":
        suites = root.findall("testsuite")
    elif root.tag == "testsuite":
        suites = [root]
    else:
        return [f"root element is <{root.tag}>, expected <testsuites> or <testsuite>"]
    if len(suites) != 1:
        problems.append(f"{len(suites)} <testsuite> elements; one per file is expected")
    for suite in suites:
        cases = suite.findall("testcase")
        for attr in ("name", "tests"):
            if suite.get(attr) is None:
                problems.append(f"<testsuite> has no '{attr}' attribute")
        expected = {
            "tests": len(cases),
            "failures": sum(1 for c in cases if c.find("failure") is not None),
            "errors": sum(1 for c in cases if c.find("error") is not None),
            "skipped": sum(1 for c in cases if c.find("skipped") is not None),
        }
        for attr, n in expected.items():
            raw = suite.get(attr)
            if raw is None:
                if attr != "tests":
                    problems.append(f"<testsuite> has no '{attr}' attribute")
                continue
            try:
                if int(raw) != n:
                    problems.append(f"<testsuite {attr}=\"{raw}\"> but the file holds {n}")
            except ValueError:
                problems.append(f"<testsuite {attr}=\"{raw}\"> is not an integer")
        for c in cases:
            for attr in ("name", "classname"):
                if not c.get(attr):
                    problems.append(f"a <testcase> has no '{attr}' attribute ({c.get('name') or '?'})")
            raw_t = c.get("time")
            if raw_t is not None:
                try:
                    float(raw_t)
                except ValueError:
                    problems.append(f"<testcase name=\"{c.get('name')}\"> time={raw_t!r} is not a number")
    return problems
