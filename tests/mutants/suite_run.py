"""Run the conformance suite (or some of its cases) in a child pytest and read its JUnit file.

Shared by the project's tests of the suite itself (tests/conformance/,
tests/end_to_end/test_conformance_*.py).
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

from junit_props import properties

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SUITE = os.path.join(REPO, "conformance", "cases")
HERE = os.path.dirname(os.path.abspath(__file__))
MUTANT = os.path.join(HERE, "mutant_emulator.py")


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
        props = properties(case)
        devs = [d for d in props.get("deviations", "").split(",") if d]
        found = (case.find(tag) for tag in ("failure", "error", "skipped"))
        problem = next((e for e in found if e is not None), None)
        message = "" if problem is None else problem.get("message", "") + "\n" + (problem.text or "")[-1500:]
        name = case.get("name", "")
        out[name] = CaseResult(name, props.get("verdict", ""), devs, props, message)
    return out


def run_suite(tmp: str, target: str, cases: Sequence[str] = (), keyword: Optional[str] = None,
              mutation: Optional[str] = None, timeout: float = 120) -> Dict[str, CaseResult]:
    """Run the given cases (test names, e.g. ``test_link.py::test_x``) against ``target``.

    With ``mutation``, the HAT is a mutant (tests/mutants/line_mutations.py): for an ``inprocess``
    target the in-process one in virtual time (mutant_target.py), for an ``emulator`` target the
    pty relay in front of the real emulator process (mutant_emulator.py)."""
    junit = os.path.join(tmp, "junit.xml")
    env = dict(os.environ)
    if mutation and target.startswith("inprocess"):
        target = "mutant:" + mutation + target[len("inprocess"):]
        env["PYTHONPATH"] = HERE + os.pathsep + env.get("PYTHONPATH", "")
        plugins = ["-p", "mutant_target"]
    else:
        plugins = []
        if mutation:
            env["BUILDHAT_EMULATOR"] = f"{sys.executable} {MUTANT} {mutation}"
    argv = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--import-mode=importlib", "-q",
            *plugins, "--target", target, "--conformance-junit", junit,
            "--transcripts", os.path.join(tmp, "tr")]
    argv += [os.path.join(SUITE, c) for c in cases] or [SUITE]
    if keyword:
        argv += ["-k", keyword]
    proc = subprocess.run(argv, cwd=REPO, env=env, timeout=timeout, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT)
    if not os.path.exists(junit):
        output = proc.stdout.decode(errors="replace")[-3000:]
        raise AssertionError(f"the suite wrote no JUnit file:\n{output}")
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
