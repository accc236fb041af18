"""The start-up case after a reset that cut a line (conformance/oracles/startup.py): bytes the HAT
was sending when it was reset, glued before the start-up's empty line, are tolerated and recorded;
a start-up without its empty line still fails. Both in virtual time (tests/torn_reset_target.py)."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest
from mutants.suite_run import REPO, SUITE, read_junit

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # tests/, where the target plugin lives
CASE = "test_firmware_facts.py::test_start_up_lines"
pytestmark = pytest.mark.timeout(300)


def _verdict(tmp: str, how: str):  # -> CaseResult
    junit = os.path.join(tmp, "junit.xml")
    env = dict(os.environ, PYTHONPATH=HERE + os.pathsep + os.environ.get("PYTHONPATH", ""))
    argv = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--import-mode=importlib", "-q",
            "-p", "torn_reset_target", "--target", f"tornreset:{how}", "--conformance-junit", junit,
            "--transcripts", os.path.join(tmp, "tr"), os.path.join(SUITE, CASE)]
    proc = subprocess.run(argv, cwd=REPO, env=env, timeout=240, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT)
    assert os.path.exists(junit), proc.stdout.decode(errors="replace")[-3000:]
    return read_junit(junit)[CASE.split("::")[1]]


def test_a_line_cut_by_the_reset_is_recorded_not_failed(tmp_path) -> None:
    result = _verdict(str(tmp_path), "torn")
    assert result.verdict == "pass", result.message
    assert "'deltat=00000' came before the start-up's empty line" in result.properties.get("notes", "")


def test_a_start_up_without_its_empty_line_fails(tmp_path) -> None:
    result = _verdict(str(tmp_path), "no-empty-line")
    assert result.verdict == "fail", (result.verdict, result.message)
    assert "Type help" in result.message
