"""record -> replay on the emulator process, and `mock` serving a recorded python-build-hat session
well enough that the real library (PyPI buildhat 0.9.0, unmodified) runs the same calls again."""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import threading
import time

import pytest
from hostlib.venvs import buildhat_python  # noqa: E402

from buildhat_conformance.cli import main as cli_main
from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.transcript import read_transcript
from buildhat_conformance.protocol.devices import DEFAULT_LAYOUT
from buildhat_conformance.transcripts.mock_serve import serve_pty
from buildhat_conformance.transcripts.record import ready_lines, record_proxy

pytestmark = pytest.mark.timeout(240)
R7 = "1737564117"   # the release buildhat 0.9.0 bundles: it uploads nothing and goes straight on

# Runs inside the library's venv (standard library + buildhat only). The calls a user would make:
# connect, list the devices, read Vin; DEPART=1 adds one the recording does not hold.
SESSION = """
import json, os, sys
os.environ.setdefault("GPIOZERO_PIN_FACTORY", "mock")   # no GPIO here
import buildhat
hat = buildhat.Hat(device=sys.argv[1])
out = {"get": hat.get(), "vin": hat.get_vin()}
if os.environ.get("DEPART") == "1":
    hat.set_leds("orange")     # sends a line, waits for no answer
with open(sys.argv[2], "w") as fh:
    json.dump(out, fh)
"""


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    python = buildhat_python("0.9.0")       # from PyPI: a failed install fails (the tests are marked)
    d = tmp_path_factory.mktemp("library")
    (d / "session.py").write_text(SESSION, encoding="utf-8")
    return str(python), d


def run_library(python: str, script: pathlib.Path, device: str, out: pathlib.Path, depart: bool = False):
    env = dict(os.environ, DEPART="1" if depart else "0")
    # (a generous bound: on a loaded machine the library's session has taken over 60 s)
    proc = subprocess.run([python, str(script), device, str(out)], env=env, capture_output=True, text=True,
                          timeout=150)
    assert proc.returncode == 0, proc.stderr
    return json.loads(out.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def recorded(library):
    """The library's session on the emulator, recorded through the proxy (the emulator at 4x)."""
    python, d = library
    target = make_target(f"emulator:{R7}?speed=4")
    status = record_proxy(target, str(d / "lib.jsonl"),
                          [python, str(d / "session.py"), "{device}", str(d / "first.json")],
                          ready=ready_lines(dict(DEFAULT_LAYOUT)), boot_timeout=30)
    assert status == 0
    return d / "lib.jsonl", json.loads((d / "first.json").read_text(encoding="utf-8"))


class MockThread:
    def __init__(self, path: pathlib.Path, strict: bool = False):
        self.stop = threading.Event()
        self.ready: list = []
        self.mocks: list = []
        self.result: list = []
        self.logs: list = []
        transcript = read_transcript(str(path))

        def run() -> None:
            self.result.append(serve_pty(transcript, strict=strict, stop=self.stop,
                                         on_ready=self.ready.append, on_mock=self._attach))
        self.thread = threading.Thread(target=run, daemon=True)
        self.thread.start()
        deadline = time.monotonic() + 10
        while not self.ready and time.monotonic() < deadline:
            time.sleep(0.01)
        self.device = self.ready[0]

    def _attach(self, mock) -> None:
        mock.log = self.logs.append
        self.mocks.append(mock)

    def close(self) -> int:
        self.stop.set()
        self.thread.join(10)
        return self.result[0]


@pytest.mark.network
def test_proxy_recording_holds_the_library_session(recorded):
    path, first = recorded
    t = read_transcript(str(path))
    assert t.meta["firmware"].startswith(R7) and t.meta["time_scale"] == 4.0
    hosts = "".join(e["bytes"] for e in t.events if e["dir"] == "host").split("\r")
    assert hosts[0] == "version" and "list" in hosts and "vin" in hosts
    assert all(e["t"] < 0 for e in t.events if e.get("line") == "Done initialising ports")
    assert first["vin"] == 8.0 and first["get"]["A"]["typeid"] == 0x30


@pytest.mark.network
def test_library_runs_the_same_calls_again_on_the_mock(library, recorded):
    python, d = library
    path, first = recorded
    mock = MockThread(path)
    try:
        second = run_library(python, d / "session.py", mock.device, d / "second.json")
        time.sleep(0.3)   # the library's last lines reach the mock
    finally:
        status = mock.close()
    assert second == first
    m = mock.mocks[0]
    assert m.departures == [] and m.skipped == [] and m.finished, mock.logs
    assert status == 0


@pytest.mark.network
def test_mock_reports_a_call_the_recording_does_not_hold(library, recorded):
    python, d = library
    path, first = recorded
    mock = MockThread(path)
    try:
        again = run_library(python, d / "session.py", mock.device, d / "third.json", depart=True)
        time.sleep(0.3)
    finally:
        mock.close()
    assert again == first      # everything recorded was still answered
    m = mock.mocks[0]
    assert m.departures == [b"ledmode 1\r"], mock.logs
    assert any("departs from the recording" in msg and "ledmode 1" in msg for msg in mock.logs)


@pytest.mark.network
def test_mock_strict_fails_on_the_departing_call(library, recorded):
    python, d = library
    path, _first = recorded
    mock = MockThread(path, strict=True)
    try:
        run_library(python, d / "session.py", mock.device, d / "fourth.json", depart=True)
    finally:
        status = mock.close()
    assert status == 1


def test_record_then_replay_on_the_emulator_process(tmp_path, capsys):
    """`record` a script on the emulator's pty (real time, 1x: a loaded machine delays a 10x
    emulator by tens of HAT milliseconds), then `replay` it there and on the other profile: the
    first matches, the second shows R4's `bias` acceptance."""
    script = tmp_path / "s.script"
    script.write_text("@name record-replay\n> version\n> vin\n> bias .4\n@wait 30\n> list\n",
                      encoding="utf-8")
    out = tmp_path / "s.jsonl"
    assert cli_main(["record", str(script), "--target", f"emulator:{R7}?speed=1", "-o", str(out)]) == 0
    meta = read_transcript(str(out)).meta
    assert meta["firmware"].startswith(R7) and meta["script"] == "s.script" and meta["date"]
    capsys.readouterr()
    assert cli_main(["replay", str(out), "--target", f"emulator:{R7}?speed=1"]) == 0
    assert "MATCH" in capsys.readouterr().out
    assert cli_main(["replay", str(out), "--target", "emulator:1670332907?speed=1"]) == 1
    text = capsys.readouterr().out
    assert "- Error    [error: not received" in text and "+ Firmware version: 1670332907" in text
