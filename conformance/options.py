"""The suite's pytest options (the ``buildhat`` group); plugin.py imports the hook so that pytest
finds it there. ``buildhat-conformance run`` (runner.py) passes its own options on as these."""
from __future__ import annotations

import os
from typing import Any

__all__ = ["pytest_addoption", "DEFAULT_MAX_TARGET_FAULTS"]

DEFAULT_MAX_TARGET_FAULTS = 5


def pytest_addoption(parser: Any) -> None:
    group = parser.getgroup("buildhat", "Build HAT conformance")
    group.addoption("--target", default="emulator", help="target URL (default: emulator)")
    group.addoption("--firmware", default=None,
                    help="firmware profile to judge against (release number, R<n> or latest); default: "
                         "detected from `version`")
    group.addoption("--operator", action="store_true", default=False,
                    help="ask a person to perform world actions (plug/unplug) and wait for Enter")
    group.addoption("--transcripts", default=os.path.join("reports", "transcripts"),
                    help="folder for one transcript per test case")
    group.addoption("--conformance-junit", default=os.path.join("reports", "junit.xml"),
                    help="JUnit XML written (and kept valid) after every case")
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
