"""The HTML report of a failing run, in a real headless Chromium at 1400x900.

The run is the real ``buildhat-conformance run`` against a planted-bug target: the reference
emulator behind tests/planted/proxy.py, which prints ``Error`` after every ``coast``. The first
screen must say what failed and why (the failing command, the wrong line), and nothing may run
off the page with every ``<details>`` opened. The screenshot is kept in
``reports/test-artefacts/`` (or ``$BUILDHAT_TEST_ARTEFACTS``) for a person to look at.
"""
from __future__ import annotations

import os
import re
import shutil
import struct
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from typing import Tuple

import browser_check  # a script beside the tests, not a package
import pytest
import repo_paths

pytestmark = pytest.mark.timeout(300)

REPO = str(repo_paths.REPO)
PROXY = os.path.join(REPO, "tests", "planted", "proxy.py")
# coast answered with Error (the planted bug), unplug/plug skipped (a cmd: target has no control
# channel), bias a known deviation of the latest release.
KEYWORD = "coast or plug or bias"


def artefacts() -> str:
    path = os.environ.get("BUILDHAT_TEST_ARTEFACTS") or os.path.join(REPO, "reports", "test-artefacts")
    os.makedirs(path, exist_ok=True)
    return path


@pytest.fixture(scope="module")
def failing_run(tmp_path_factory) -> Tuple[str, str]:
    """The report's path and the run's terminal output."""
    cwd = tmp_path_factory.mktemp("planted")
    target = f"cmd:{sys.executable} {PROXY} wrong --booted"
    proc = subprocess.run([sys.executable, "-m", "buildhat_conformance.cli", "run", "--target", target,
                           "-k", KEYWORD], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=240)
    assert proc.returncode == 1, proc.stdout[-3000:]       # conformance failures, not a crash
    last = [ln for ln in proc.stdout.splitlines() if ln.startswith("conformance: ")]
    assert last and " fail" in last[-1] and "skip" in last[-1], proc.stdout[-2000:]
    html = os.path.join(cwd, "reports", "latest", "index.html")
    assert os.path.isfile(html), proc.stdout[-2000:]
    return html, proc.stdout


@pytest.fixture(scope="module")
def failing_report(failing_run) -> str:
    return failing_run[0]


def test_terminal_says_what_runs_and_where_the_report_is(failing_run) -> None:
    html, out = failing_run
    lines = out.splitlines()
    legend = next(i for i, ln in enumerate(lines) if ln.startswith("letters: "))
    for letter in (". pass", "F fail", "s skip", "K known deviation", "I informational", "T target fault",
                   "N not run"):
        assert letter in lines[legend]
    # The coast run-down case waits for the motor in real time (seconds): named while it runs,
    # on a line of its own between the progress letters.
    slow = [ln for ln in lines if re.fullmatch(r"  … test_drive\.py::test_coast_lets_the_motor_run_down "
                                               r"\(\d+ s\)", ln)]
    assert slow, out[:3000]
    assert lines.index(slow[0]) > legend
    closing = [ln for ln in lines if ln.startswith("conformance: ")][-1]
    m = re.fullmatch(r"conformance: FAILS: (\d+) finding\(s\) against the protocol \((\d+) of \d+ cases "
                     r"skipped: [^)]+\); (\d+) case\(s\): (.*) in \d+ s; report: (.*)", closing)
    assert m, closing
    counts = dict((w, int(n)) for n, w in re.findall(r"(\d+) ([a-z -]+?)(?:,|$)", m.group(4)))
    assert sum(counts.values()) == int(m.group(3)) and counts["fail"] >= 1 and counts["skip"] >= 1
    assert counts["fail"] == int(m.group(1)) and counts["skip"] == int(m.group(2))
    assert os.path.realpath(m.group(5)) == os.path.realpath(html)


def test_failing_report_reads_in_the_first_screen(failing_report) -> None:
    with open(failing_report, encoding="utf-8") as fh:
        text = fh.read()
    head = text[:text.index("id=by-requirement")]
    assert "FAILS:" in head and re.search(r"<b>\d+</b> fail", head)
    for verdict in ("target fault", "not run", "known deviation", "skip"):
        assert f"</b> {verdict}</a>" in head            # every verdict has its count, zero or not
    # the failing exchange: the command sent and the wrong line, marked
    assert "&gt; coast</code>" in head
    # (side by side where the message states both replies, else the reply with the wrong line marked)
    assert (re.search(r"<tr class=first><td>.*?</td><td>Error</td></tr>", head)
            or "<span class=first>&lt; Error</span>" in head), head[:4000]
    # skip reasons visible (not hover text) with what to connect
    skips = head[head.index("id=skips"):]
    assert "needs unplugging a device" in skips and "has no &#x27;unplug&#x27; control" in skips
    # known deviations explained with their sections of the project's docs/FIRMWARE-BEHAVIOUR.md
    dev = text[text.index("id=deviations"):text.index("id=plots")]
    assert "BIAS-REMOVED" in dev and "docs/FIRMWARE-BEHAVIOUR.md#fb-" in dev and "#fb-doc-bias" in dev
    assert "pwmparams" in dev and "FIRMWARE-FACTS" not in text
    assert "object at 0x" not in text                  # no pytest reprs anywhere


@pytest.mark.skipif(browser_check.chromium() is None,
                    reason="chromium is not installed (Debian: apt-get install chromium); "
                           "the report's layout is not checked in a browser")
def test_failing_report_fits_1400_px_in_chromium(failing_report) -> None:
    exe = browser_check.chromium()
    assert exe is not None
    shot = os.path.join(artefacts(), "report-failing-run-1400x900.png")
    # Two Chromium processes side by side: the screenshot, and the layout with every details open.
    with ThreadPoolExecutor(2) as pool:
        shooting = pool.submit(browser_check.screenshot, failing_report, shot, exe)
        measuring = pool.submit(browser_check.measure, failing_report, exe)
        shooting.result()
        found = measuring.result()
    with open(shot, "rb") as fh:
        png = fh.read()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">II", png[16:24]) == (browser_check.WIDTH, browser_check.HEIGHT)
    shutil.copy(failing_report, os.path.join(artefacts(), "report-failing-run.html"))

    assert found["width"] == browser_check.WIDTH
    assert found["overflow"] == [], "\n".join(map(str, found["overflow"]))
    # what failed is on the first screen: the failures table and its first group start above 900 px
    assert 0 < found["failures_top"] < browser_check.HEIGHT // 2, found
    assert 0 < found["first_group_bottom"] <= browser_check.HEIGHT, found


@pytest.mark.skipif(browser_check.chromium() is None, reason="chromium is not installed (Debian: apt-get "
                                                               "install chromium)")
def test_the_probe_sees_a_line_that_runs_off_the_page(tmp_path) -> None:
    """The layout check can fail: a long unwrapped line inside a closed <details> is found."""
    page = tmp_path / "wide.html"
    page.write_text("<!DOCTYPE html><html><body><h2 id=failures>x</h2><details><summary>s</summary>"
                    f"<pre style='white-space:pre'>{'E   assert ' + 'x' * 400}</pre></details></body></html>",
                    encoding="utf-8")
    found = browser_check.measure(str(page), browser_check.chromium() or "")
    assert any("runs off the right edge" in o and "PRE" in o for o in found["overflow"]), found
