"""pytest plugin for host libraries' own tests: the ``buildhat_emulator`` fixtures.

One emulator per test (a fresh HAT each time)::

    def test_motor_runs(buildhat_emulator):
        ser = serial.Serial(buildhat_emulator.path, 115200)     # a real pty in raw mode
        buildhat_emulator.control("@pos 0 90")                  # world actions, see --help

    @pytest.mark.buildhat_emulator(firmware="R5", devices={3: "0x30", 1: None}, speed=1)
    def test_old_firmware(buildhat_emulator): ...

One emulator for the whole session, for libraries that keep one connection per process (python-build-hat
opens the serial port once and keeps it until the interpreter exits)::

    @pytest.fixture(scope="session")
    def buildhat_emulator_options():                 # optional: the session emulator's options
        return {"firmware": "1737564117", "devices": {1: "0x3E"}}

    def test_distance(buildhat_emulator_shared):
        buildhat.Hat(device=buildhat_emulator_shared.path)     # the same pty path for every test
        buildhat_emulator_shared.control("@data 1 0 E8 03")    # undone after the test

The shared emulator stays powered across tests, as a HAT on a bench does; after each test, what the test
changed through ``.control()`` is undone (readings back to the device models, shafts released, faults
cleared, devices re-plugged as in the layout, Vin back to 8.00 V). The emulator is stopped at interpreter
exit, after the library's own exit handler has sent its last lines (no traceback from a closed pty), and
``BUILDHAT_EMULATOR_CONTROL`` is exported so that ``GPIOZERO_PIN_FACTORY=buildhat_emulator`` works in-process.

Both fixtures start ``buildhat-emulator --pty --control <socket> --transcript <file>`` (emulator/
fixture_process.py), wait until it has settled (not with ``bootloader=True``), and yield an
:class:`EmulatorProcess`. When a test fails, its failure message gets the host-lint findings of that test,
the emulator's stderr (a ``--strict-host`` stop names the offending line) and the path of the transcript,
which is kept. Marker / options: ``firmware``, ``devices`` (port -> SPEC or None, over the default layout),
``version_string``, ``speed``, ``baud`` (default: a HAT's 115200-baud wire both ways, as the HAT a library
meets; 0 for an unpaced link), ``fast_setup`` (devices set up faster than a HAT's 2400 baud; default the real
rate), ``bootloader``, ``settle``, ``args`` (extra arguments).

The plugin adds no command-line options and imports only the standard library and pytest at load time.
"""
from __future__ import annotations

import os
import re
import weakref
from typing import Any, Dict, Iterator, Optional, Tuple

import pytest

from .emulator_process import START_TIMEOUT, EmulatorProcess

__all__ = ["EmulatorProcess", "buildhat_emulator", "buildhat_emulator_shared", "buildhat_emulator_session",
           "buildhat_emulator_options", "START_TIMEOUT"]

MARKER = "buildhat_emulator"
# item.stash keys: the emulator a test ran on and the host lines before it; whether the test failed.
_RUN = pytest.StashKey[Tuple[EmulatorProcess, int]]()
_FAILED = pytest.StashKey[bool]()


def pytest_configure(config: Any) -> None:
    config.addinivalue_line(
        "markers", f"{MARKER}(firmware=None, devices=None, speed=1.0, ...): options for the "
        "buildhat_emulator fixture (see buildhat_conformance.emulator.host_fixtures.pytest_plugin)")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: Any, call: Any) -> Iterator[None]:
    outcome = yield
    report = outcome.get_result()
    run = item.stash.get(_RUN, None)
    if run is None or not report.failed:
        return
    item.stash[_FAILED] = True
    emulator, since = run
    text = emulator.details(since_line=since)
    longrepr = report.longrepr
    if hasattr(longrepr, "addsection"):
        longrepr.addsection("buildhat-emulator", text)      # printed with the failure itself
    else:
        report.sections.append(("buildhat-emulator", text))


def _start(options: Dict[str, Any], keep_dir: str, link: Optional[str] = None) -> EmulatorProcess:
    options = dict(options)
    settle = options.pop("settle", True)
    emulator = EmulatorProcess(keep_dir=keep_dir, link=link, **options)
    try:
        if settle and not options.get("bootloader"):
            emulator.wait_settled()
    except BaseException:
        emulator.close(keep=True)
        raise
    return emulator


def _lines_so_far(emulator: EmulatorProcess) -> int:
    summary = emulator.lint()
    return int(summary.get("lines", 0)) if summary else 0


def _dir_name(nodeid: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", nodeid)[-60:] or "test"


@pytest.fixture
def buildhat_emulator(request: Any, tmp_path_factory: Any) -> Iterator[EmulatorProcess]:
    """A fresh ``buildhat-emulator --pty`` child for this test (see the module docstring)."""
    marker = request.node.get_closest_marker(MARKER)
    keep_dir = str(tmp_path_factory.mktemp("buildhat-emulator-" + _dir_name(request.node.name)))
    emulator = _start(dict(marker.kwargs) if marker else {}, keep_dir)
    request.node.stash[_RUN] = (emulator, 0)
    try:
        yield emulator
    finally:
        emulator.close(keep=request.node.stash.get(_FAILED, False))


@pytest.fixture(scope="session")
def buildhat_emulator_options() -> Dict[str, Any]:
    """Options of the session's shared emulator (override this fixture in a conftest.py)."""
    return {}


class _Shared:
    """The session's emulator and whether any test on it failed (then its files are kept)."""

    def __init__(self, emulator: EmulatorProcess):
        self.emulator = emulator
        self.failed = False

    def stop(self) -> None:
        self.emulator.close(keep=self.failed)


@pytest.fixture(scope="session")
def buildhat_emulator_session(buildhat_emulator_options: Dict[str, Any], tmp_path_factory: Any) -> Any:
    """The session's emulator (use ``buildhat_emulator_shared`` in tests: it also restores the world)."""
    keep_dir = str(tmp_path_factory.mktemp("buildhat-emulator-session"))
    emulator = _start(buildhat_emulator_options, keep_dir, link=os.path.join(keep_dir, "serial"))
    os.environ.update(emulator.environment())
    shared = _Shared(emulator)
    # Stopped at interpreter exit, not at session teardown: a library still holds the pty, and its exit
    # handler writes its last lines to it. python-build-hat's is a weakref.finalize; finalizers run at exit
    # newest first, so one made now (before any test connected the library) runs after it. The bound
    # method keeps ``shared`` alive until then.
    weakref.finalize(shared, shared.stop)
    return shared


@pytest.fixture
def buildhat_emulator_shared(request: Any, buildhat_emulator_session: Any) -> Iterator[EmulatorProcess]:
    """The session's emulator for this test; what the test changed through ``.control()`` is undone after."""
    shared = buildhat_emulator_session
    emulator = shared.emulator
    if not emulator.alive():
        raise emulator.failure(f"(the session's emulator) exited with status {emulator.process.poll()}")
    request.node.stash[_RUN] = (emulator, _lines_so_far(emulator))
    try:
        yield emulator
    finally:
        if request.node.stash.get(_FAILED, False):
            shared.failed = True
        emulator.restore()
