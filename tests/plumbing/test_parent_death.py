"""Children that end with their parent (plumbing/parent_death.py): a grandchild started with
``die_with_parent()`` gets its signal when the child that started it is killed with SIGKILL (Linux)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from process_tree import alive

from buildhat_conformance.plumbing.parent_death import set_parent_death_signal

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="prctl is Linux only")

# The child: starts a sleeping grandchild that dies with it, prints the grandchild's pid, then waits.
CHILD = """
import subprocess, sys, time
from buildhat_conformance.plumbing.parent_death import die_with_parent
g = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"], preexec_fn=die_with_parent())
print(g.pid, flush=True)
time.sleep(120)
"""


def _alive(pid: int) -> bool:
    return pid in alive({pid})      # a zombie has died already


def test_the_grandchild_dies_when_its_parent_is_killed():
    child = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, text=True)
    assert child.stdout is not None
    grandchild = int(child.stdout.readline())
    try:
        assert _alive(grandchild)
        child.send_signal(signal.SIGKILL)
        child.wait()
        deadline = time.monotonic() + 30
        while _alive(grandchild) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(grandchild)
    finally:
        if _alive(grandchild):
            os.kill(grandchild, signal.SIGKILL)


def test_the_signal_can_be_set_here():
    try:
        assert set_parent_death_signal(signal.SIGTERM) is True
    finally:
        set_parent_death_signal(0)          # 0 clears it: this test process keeps its own fate
