"""Terminal progress of a conformance run, for a person watching it.

- a legend of the verdict letters before the first case;
- the name of a case still running after 2 s (``  … test_x (3 s)``), printed at the time, then
  again every 10 s, so a long wait on the HAT never looks like a hang;
- one closing line with the run's verdict (how much was skipped, and why), the counts per verdict
  and where the report is.

The slow-case line comes from a timer thread. While a case runs, pytest captures file
descriptor 1, so the thread writes to a duplicate of the terminal's descriptor taken when
nothing was captured.
"""
from __future__ import annotations

import os
import sys
import threading
import time
from typing import Any, Dict, Optional

import pytest

__all__ = ["LEGEND", "Progress", "slow_notice"]

FIRST_NOTICE_S = 2.0
REPEAT_S = 10.0

#: pytest's letters and the suite's own (plugin.py's pytest_report_teststatus).
LEGEND = ("letters: . pass  F fail  E error in set-up/tear-down  s skip  K known deviation  "
          "I informational  T target fault  N not run")

_ORDER = ("fail", "target-fault", "not-run", "pass", "known deviation", "informational", "skip")


def slow_notice(nodeid: str, seconds: float) -> str:
    """The line shown for a case still running: its name without the folder, and its age."""
    name = nodeid.rsplit("/", 1)[-1]
    return f"  … {name} ({seconds:.0f} s)"


def pytest_addoption(parser: Any) -> None:
    group = parser.getgroup("buildhat", "Build HAT conformance")
    group.addoption("--conformance-html", default=None,
                    help="where the HTML report of this run will be (named in the closing line)")


@pytest.hookimpl(trylast=True)      # after the terminal reporter exists
def pytest_configure(config: Any) -> None:
    # Only where the terminal is: an xdist controller or a plain run, never a worker.
    if hasattr(config, "workerinput") or config.pluginmanager.get_plugin("terminalreporter") is None:
        return
    config.pluginmanager.register(Progress(config), "buildhat-conformance-progress")


class Progress:
    def __init__(self, config: Any):
        self.config = config
        self.started = time.monotonic()
        self.running: Dict[str, float] = {}          # nodeid -> start (monotonic)
        self.shown: Dict[str, float] = {}            # nodeid -> next notice due (seconds into the case)
        self.noticed = False
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.fd: Optional[int] = None
        self.thread: Optional[threading.Thread] = None

    @property
    def tr(self) -> Any:
        return self.config.pluginmanager.get_plugin("terminalreporter")

    # -- start and legend -----------------------------------------------------------------
    def pytest_sessionstart(self, session: Any) -> None:
        try:
            # Nothing is captured now; this descriptor stays the terminal while a case runs.
            self.fd = os.dup(sys.stdout.fileno())
        except (AttributeError, OSError, ValueError):
            self.fd = None        # no real stdout (embedded pytest): no slow-case lines
        if self.fd is not None:
            self.thread = threading.Thread(target=self._watch, name="conformance-progress", daemon=True)
            self.thread.start()

    def pytest_collection_finish(self, session: Any) -> None:
        if session.items and not self.config.option.collectonly:
            self.tr.write_line(LEGEND)

    # -- slow cases -----------------------------------------------------------------------
    def pytest_runtest_logstart(self, nodeid: str, location: Any) -> None:
        with self.lock:
            self.running[nodeid] = time.monotonic()
            self.shown[nodeid] = FIRST_NOTICE_S

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_logreport(self, report: Any) -> None:
        if self.noticed:
            # The thread's lines ended with a newline pytest did not see: tell its writer the
            # line is empty again, so the "[ 40%]" column stays where it belongs.
            tw = getattr(self.tr, "_tw", None)
            if tw is not None and hasattr(tw, "_current_line"):
                tw._current_line = ""
            self.noticed = False

    def pytest_runtest_logfinish(self, nodeid: str, location: Any) -> None:
        with self.lock:
            self.running.pop(nodeid, None)
            self.shown.pop(nodeid, None)

    def _watch(self) -> None:
        while not self.stop.wait(0.25):
            now = time.monotonic()
            lines = []
            with self.lock:
                for nodeid, t0 in self.running.items():
                    age = now - t0
                    if age >= self.shown[nodeid]:
                        lines.append(slow_notice(nodeid, age))
                        self.shown[nodeid] = (age // REPEAT_S + 1) * REPEAT_S if age >= REPEAT_S \
                            else REPEAT_S
            if lines and self.fd is not None:
                try:
                    os.write(self.fd, ("\n" + "\n".join(lines) + "\n").encode("utf-8", "replace"))
                    self.noticed = True
                except OSError:
                    return

    # -- the closing line -------------------------------------------------------------------
    def pytest_unconfigure(self, config: Any) -> None:
        self.stop.set()
        if self.thread is not None:
            self.thread.join(timeout=1.0)
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        line = self.closing_line()
        if line:
            self.tr.write_line(line, bold=True)

    def closing_line(self) -> str:
        run = self.config.pluginmanager.get_plugin("buildhat-conformance-run")
        results = getattr(run, "results", None) or {}
        if not results:
            return ""
        counts: Dict[str, int] = {}
        for cls, _ids in results.values():
            counts[cls] = counts.get(cls, 0) + 1
        order = list(_ORDER) + sorted(set(counts) - set(_ORDER))
        text = ", ".join(f"{counts[c]} {c}" for c in order if counts.get(c))
        html = self.config.getoption("conformance_html")
        junit = getattr(getattr(run, "junit", None), "path", "")
        where = f"report: {html}" if html else f"JUnit: {junit}"
        took = time.monotonic() - self.started
        from .run_outcome import banner

        word = banner(results, getattr(run, "skip_reasons", {}), bool(getattr(run, "has_control", False)))
        return f"conformance: {word}; {len(results)} case(s): {text} in {took:.0f} s; {where}"
