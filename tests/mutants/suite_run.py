"""Run the conformance suite (or some of its cases) in a child pytest and read its JUnit file.

Shared by the project's tests of the suite itself (tests/test_conformance_*.py).
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SUITE = os.path.join(REPO, "conformance")
MUTANT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "mutant_emulator.py")


@dataclass
class CaseResult:
    name: str
    verdict: str
    deviations: List[str]
    properties: Dict[str, str]
    message: str = ""


def read_junit(path: str) -> Dict[str, CaseResult]:
    out = {}
    for case in ET.parse(path).getroot().iter("testcase"):
        props = {p.get("name"): p.get("value") for p in case.iter("property")}
        devs = [d for d in props.get("deviations", "").split(",") if d]
        problem = case.find("failure")
        problem = problem if problem is not None else case.find("error")
        message = "" if problem is None else problem.get("message", "") + "\n" + (problem.text or "")[-1500:]
        out[case.get("name")] = CaseResult(case.get("name"), props.get("verdict", ""), devs, props, message)
    return out


def run_suite(tmp: str, target: str, cases: Sequence[str] = (), keyword: Optional[str] = None,
              mutation: Optional[str] = None, timeout: float = 120) -> Dict[str, CaseResult]:
    """Run the given cases (test names, e.g. ``test_link.py::test_x``) against ``target``."""
    junit = os.path.join(tmp, "junit.xml")
    argv = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--import-mode=importlib", "-q",
            "--target", target, "--conformance-junit", junit, "--transcripts", os.path.join(tmp, "tr")]
    argv += [os.path.join(SUITE, c) for c in cases] or [SUITE]
    if keyword:
        argv += ["-k", keyword]
    env = dict(os.environ)
    if mutation:
        env["BUILDHAT_EMULATOR"] = f"{sys.executable} {MUTANT} {mutation}"
    subprocess.run(argv, cwd=REPO, env=env, timeout=timeout, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    return read_junit(junit)


# pytest's own closing line ("2 passed, 1 target-fault, 15 not-run in 15.81s"), whatever the
# suite's own summary prints after it.
_PYTEST_SUMMARY = re.compile(r"^(?:\d+ [a-z -]+, )*\d+ [a-z -]+ in [\d.]+s(?: \([\d:]+\))?$")
_COUNTED = re.compile(r"(\d+) (?:passed|failed|errors?|skipped|target-fault|not-run|known deviation|"
                      r"informational)")


def reported_case_count(output: str) -> int:
    """How many cases pytest itself says it ran (its summary line), 0 if it printed none."""
    for line in reversed(output.strip().splitlines()):
        if _PYTEST_SUMMARY.match(line.strip()):
            return sum(int(n) for n in _COUNTED.findall(line))
    return 0
