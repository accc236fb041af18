"""The suite's pytest options (the ``buildhat`` group), a plugin of its own (plugin/__init__.py).
``buildhat-conformance run`` (conformance/runner.py) passes its own options on as these.

Without ``--conformance-junit`` a run writes a new folder, ``reports/pytest/<time>-<pid>/``, so a
plain ``pytest`` over the suite (even ``--collect-only``) never overwrites an earlier report."""
from __future__ import annotations

import os
import time
from typing import Any

__all__ = ["pytest_addoption", "DEFAULT_MAX_TARGET_FAULTS", "settle_output_paths"]

DEFAULT_MAX_TARGET_FAULTS = 5


def pytest_addoption(parser: Any) -> None:
    group = parser.getgroup("buildhat", "Build HAT conformance")
    group.addoption("--target", default="emulator", help="target URL (default: emulator)")
    group.addoption("--firmware", default=None,
                    help="firmware profile to judge against (release number, R<n> or latest); default: "
                         "detected from `version`")
    group.addoption("--operator", action="store_true", default=False,
                    help="ask a person to perform world actions (plug/unplug) and wait for Enter")
    group.addoption("--transcripts", default=None,
                    help="folder for one transcript per test case (default: transcripts/ beside the JUnit "
                         "file)")
    group.addoption("--conformance-junit", default=None,
                    help="JUnit XML written (and kept valid) after every case (default: a new "
                         "reports/pytest/<time>-<pid>/junit.xml)")
    group.addoption("--speed", default="10",
                    help="time scale added to emulator URLs that give none (default 10)")
    group.addoption("--max-target-faults", type=int, default=DEFAULT_MAX_TARGET_FAULTS,
                    help="after this many target faults in a row (silent, dead, restarted, garbled, not "
                         "reading) stop talking to the target and report the remaining cases as not-run "
                         f"(default {DEFAULT_MAX_TARGET_FAULTS}; 0: never stop); a target that can reset "
                         "the HAT is reset once first")
    group.addoption("--image", default=None, metavar="FILE",
                    help="the release's firmware image, loaded again if the run resets a dead HAT (a real "
                         "HAT restarts in its bootloader); with --signature")
    group.addoption("--signature", default=None, metavar="FILE", help="the image's 64-byte signature")


def settle_output_paths(config: Any) -> None:
    """Fill in the JUnit and transcript paths the user left out: a new folder per run, never a
    path an earlier run wrote. Idempotent (xdist workers receive the controller's values)."""
    junit = config.getoption("conformance_junit")
    if junit is None:
        stamp = time.strftime("%Y%m%d-%H%M%S") + f"-{os.getpid()}"
        junit = os.path.join("reports", "pytest", stamp, "junit.xml")
        config.option.conformance_junit = junit
    if config.getoption("transcripts") is None:
        config.option.transcripts = os.path.join(os.path.dirname(os.path.abspath(junit)), "transcripts")
