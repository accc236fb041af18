"""Adding a fuzz oracle is one new module in fuzz/oracles/ (issue 36): a planted module, and nothing else,
makes `buildhat-conformance fuzz` run its check on every answer, count it in the summary, give it a JUnit
case, report its finding with a script that `--reproduce` replays, and list it in `--help`.

The module is written into a temporary folder that the command's process adds to the
``buildhat_conformance.fuzz.oracles`` package's path (as a file dropped into fuzz/oracles/ would be
found), so the source tree and the other tests never see it."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import List

import pytest

PLANTED = textwrap.dedent('''
    """A test's planted oracle: no answer may mention the firmware's version."""
    from buildhat_conformance.fuzz.oracles.registry import Answer, Oracle, register

    def _check(answer: Answer):
        if b"Firmware version" in answer.received:
            yield PLANTED.problem(f"{answer.side} ({answer.release}) printed its version")

    PLANTED = register(Oracle("planted", "a test's planted oracle: no answer mentions the firmware version",
                              priority=10, per_answer=True, check=_check))
''')

# The command's own entry point, in a process whose fuzz/oracles/ package also reads the folder argv[1].
COMMAND = ("import sys\n"
           "import buildhat_conformance.fuzz.oracles as oracles\n"
           "oracles.__path__.append(sys.argv[1])\n"
           "from buildhat_conformance.cli import main\n"
           "sys.exit(main(sys.argv[2:]))\n")
# The JUnit cases of a campaign without --against on the emulator (no firmware in the loop).
OWN_CASES = ["liveness", "fate", "state", "hygiene"]


@pytest.fixture
def planted_folder(tmp_path: Path) -> Path:
    folder = tmp_path / "added_oracles"
    folder.mkdir()
    (folder / "planted_oracle.py").write_text(PLANTED, encoding="utf-8")
    return folder


def _command(folder: Path, *args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, BUILDHAT_CONFORMANCE_JOBS="1")
    return subprocess.run([sys.executable, "-c", COMMAND, str(folder), *args], capture_output=True, text=True,
                          timeout=240, env=env)


def _cases(junit: Path) -> List[ET.Element]:
    return ET.parse(junit).getroot().findall("testcase")


def test_a_planted_oracle_module_is_listed_in_fuzz_help(planted_folder: Path, tmp_path: Path):
    res = _command(planted_folder, "fuzz", "--help")
    assert res.returncode == 0, res.stderr
    listed = " ".join(res.stdout.split())          # (argparse wraps the lines)
    assert "planted: a test's planted oracle: no answer mentions the firmware version" in listed
    assert "liveness: every step's fence answers" in listed          # beside the fuzzer's own
    empty = tmp_path / "no_oracles"
    empty.mkdir()
    assert "planted" not in _command(empty, "fuzz", "--help").stdout    # the module, not the driver


def test_a_planted_oracle_module_runs_in_the_campaign_summary_junit_and_findings(planted_folder: Path,
                                                                                  tmp_path: Path):
    out = tmp_path / "out"
    res = _command(planted_folder, "fuzz", "-t", "inprocess:R7", "--budget", "3x", "--seed", "1",
                   "--steps", "5", "--confirm", "1", "--shrink-time", "5", "--no-database", "-q",
                   "-o", str(out))
    assert res.returncode == 1, res.stdout + res.stderr          # a finding
    summary = res.stdout
    checks = next(line for line in summary.splitlines() if line.startswith("  checks: "))
    assert "planted " in checks and "liveness " in checks, summary     # it ran, counted like the others
    assert "FINDING [planted] (reproduced 1/1" in summary, summary
    assert "target (R7) printed its version" in summary
    cases = {case.get("name"): case for case in _cases(out / "junit.xml")}
    assert list(cases) == OWN_CASES + ["planted"]
    failure = cases["planted"].find("failure")
    assert failure is not None and failure.get("type") == "fuzz.planted"
    assert cases["fate"].find("failure") is None         # the fuzzer's own found nothing on the emulator
    script = out / "planted.script"
    assert script.is_file() and (out / "planted.target.jsonl").is_file()
    assert "@name fuzz finding (planted)" in script.read_text(encoding="utf-8")
    again = _command(planted_folder, "fuzz", "--reproduce", str(script), "-t", "inprocess:R7")
    assert again.returncode == 1 and "reproduced" in again.stdout, again.stdout + again.stderr


def test_without_the_module_the_same_campaign_has_no_planted_oracle(tmp_path: Path):
    # The campaign above, with the folder empty: no finding, no case, no count.
    empty = tmp_path / "no_oracles"
    empty.mkdir()
    out = tmp_path / "out"
    res = _command(empty, "fuzz", "-t", "inprocess:R7", "--budget", "3x", "--seed", "1", "--steps", "5",
                   "--no-database", "-q", "-o", str(out))
    assert res.returncode == 0, res.stdout + res.stderr
    assert "planted" not in res.stdout
    assert [case.get("name") for case in _cases(out / "junit.xml")] == OWN_CASES
