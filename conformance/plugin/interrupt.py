"""pytest plugin loaded by ``buildhat-conformance run`` in its pytest child: an interrupted run
ends cleanly and says so in its JUnit file.

SIGTERM (what the runner sends on Ctrl-C or when it is itself terminated, and the parent-death
signal if it is killed) becomes a KeyboardInterrupt, so pytest finishes the session: the
target is closed (the emulator and ``cmd:`` programs end), and the JUnit file is written with
every case that ran. The file carries the testsuite property ``partial=true`` from the start
of the run until the run ends normally, so a file left by a killed run says what it is.
"""
from __future__ import annotations

import signal
from typing import Any

import pytest

PARTIAL = "partial"
_RUN_PLUGIN = "buildhat-conformance-run"


def _junit(config: Any) -> Any:
    run = config.pluginmanager.get_plugin(_RUN_PLUGIN)
    return getattr(run, "junit", None)


def _on_term(_sig: int, _frame: Any) -> None:
    raise KeyboardInterrupt


def pytest_configure(config: Any) -> None:
    if not hasattr(config, "workerinput"):
        signal.signal(signal.SIGTERM, _on_term)


@pytest.hookimpl(trylast=True)
def pytest_sessionstart(session: Any) -> None:
    junit = _junit(session.config)
    if junit is not None:
        junit.set_property(PARTIAL, "true")
        junit.write()


@pytest.hookimpl(tryfirst=True)
def pytest_sessionfinish(session: Any, exitstatus: Any) -> None:
    junit = _junit(session.config)
    if junit is None:
        return
    if exitstatus == pytest.ExitCode.INTERRUPTED or session.shouldstop:
        junit.set_property(PARTIAL, "true")   # the run's own sessionfinish writes the file next
    else:
        junit.properties = [(n, v) for n, v in junit.properties if n != PARTIAL]
