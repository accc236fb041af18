"""A plain `pytest conformance/cases` (no --conformance-junit) never writes over an earlier report:
it takes a new reports/pytest/<time>-<pid>/ folder of its own (conformance/plugin/options.py)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from repo_paths import REPO

CASES = REPO / "conformance" / "cases"


def _pytest(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pytest", str(CASES), "-p", "no:cacheprovider", "-q",
                           "--target", "inprocess", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300)


def test_collect_only_leaves_an_earlier_report_alone(tmp_path):
    earlier = tmp_path / "reports" / "junit.xml"
    earlier.parent.mkdir()
    earlier.write_text("<testsuites>earlier</testsuites>")
    done = _pytest(tmp_path, "--collect-only")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert earlier.read_text() == "<testsuites>earlier</testsuites>"
    assert not (tmp_path / "reports" / "transcripts").exists()


def test_each_plain_run_writes_a_folder_of_its_own(tmp_path):
    for _ in range(2):
        done = _pytest(tmp_path, "-k", "test_version")
        assert done.returncode in (0, 1), done.stdout[-2000:] + done.stderr[-2000:]
    runs = sorted((tmp_path / "reports" / "pytest").iterdir())
    assert len(runs) == 2, runs
    assert all((run / "junit.xml").is_file() for run in runs)
    assert not (tmp_path / "reports" / "junit.xml").exists()
