"""`record` of a script with no `@wait` between its lines, then `mock`: the mock answers each host line
with its own reply, found by the protocol's reply shape (the CR's CRLF, FIRMWARE-FACTS §1), though every
line was sent before the first answer came. The real python-build-hat library is the client."""
from __future__ import annotations

import json
import os
import pathlib
import shlex
import subprocess
import sys

import pytest
from hostlib.venvs import buildhat_python
from repo_paths import TESTS

from buildhat_conformance.harness.transcript import read_transcript
from buildhat_conformance.transcripts.mock import exchanges_of

# What python-build-hat 0.9.0 sends when it connects (serinterface.py), back to back, no waits.
SELECT_ALL = "port 0 ; select ; port 1 ; select ; port 2 ; select ; port 3 ; select ; echo 0"
# The lines back to back as the library sends them; the closing @wait only keeps the recording open
# for the answers.
SCRIPT = f";; the library's own start, with no @wait between its lines\n> version\n> {SELECT_ALL}\n> list\n" \
    "@wait 3000\n"
# The HAT holds its answers until the host has been quiet this long (tests/held_hat.py): a `record`
# that sends the lines back to back has sent all three before the first answer, on any machine; one
# that waited for an answer before its next line could not have.
QUIET_S = 1.5
VERSION = "Firmware version: 1737564117"


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> pathlib.Path:
    """Recorded on the emulator (``--stdio --booted``, real time) behind tests/held_hat.py."""
    here = tmp_path_factory.mktemp("rec")
    (here / "connect.script").write_text(SCRIPT, encoding="utf-8")
    out = here / "connect.jsonl"
    hat = f"{shlex.quote(sys.executable)} {shlex.quote(str(TESTS / 'held_hat.py'))} {QUIET_S} --booted"
    proc = subprocess.run([sys.executable, "-m", "buildhat_conformance", "record", "connect.script",
                           "-t", f"cmd:{hat}", "-o", str(out)], cwd=here, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    return out


def test_every_line_was_sent_before_the_first_answer(recording):
    events = read_transcript(str(recording)).events
    hosts = [i for i, e in enumerate(events) if e.get("dir") == "host"]
    first_answer = next(i for i, e in enumerate(events) if e.get("dir") == "hat" and float(e["t"]) >= 0)
    assert [events[i]["bytes"] for i in hosts if float(events[i]["t"]) >= 0] == \
        ["version\r", SELECT_ALL + "\r", "list\r"], events
    assert hosts[-1] < first_answer, "record waited for an answer before sending its next line"


def test_each_line_gets_its_own_reply(recording):
    ex = {e.host: b"".join(d for _t, d in e.output) for e in exchanges_of(read_transcript(str(recording)))}
    assert ex[b"version\r"].startswith(b"\r\n" + VERSION.encode()), ex[b"version\r"]
    assert ex[(SELECT_ALL + "\r").encode()] == b"\r\n"           # echo 0: just the CR's CRLF
    listing = ex[b"list\r"]
    assert listing.startswith(b"\r\nP0: ") and VERSION.encode() not in listing
    for port in range(4):
        assert f"\r\nP{port}: ".encode() in listing


LIBRARY_CLIENT = """
import json, os, sys
os.environ.setdefault("GPIOZERO_PIN_FACTORY", "mock")
from buildhat import Hat
hat = Hat(device=sys.argv[1])
print(json.dumps({str(k): v for k, v in hat.get().items()}), flush=True)
os._exit(0)   # skip the library's shutdown lines, which the recording does not hold
"""


@pytest.mark.network
@pytest.mark.timeout(300)
def test_python_build_hat_connects_to_the_mock(recording, tmp_path):
    python = buildhat_python("0.9.0")       # from PyPI: a failed install fails (the test is marked)
    mock = subprocess.Popen([sys.executable, "-m", "buildhat_conformance", "mock", str(recording), "--pty"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        device = mock.stdout.readline().strip()
        assert device.startswith("/dev/"), mock.stderr.read()
        client = subprocess.run([str(python), "-c", LIBRARY_CLIENT, device], capture_output=True, text=True,
                                timeout=60, env=dict(os.environ, GPIOZERO_PIN_FACTORY="mock"))
    finally:
        mock.terminate()
        _out, log = mock.communicate(timeout=10)
    assert client.returncode == 0, client.stderr + "\nmock: " + log
    devices = json.loads(client.stdout.strip().splitlines()[-1])
    assert set(devices) == {"A", "B", "C", "D"}, devices                  # the library names ports A-D
    assert devices["A"]["typeid"] == 0x30 and devices["A"]["connected"], devices  # the recorded layout
    assert not devices["D"]["connected"], devices
    # every recorded line was answered (the library may also send lines the recording does not
    # hold, e.g. a second `version` or `port 1 ; on` for the matrix: those the mock leaves unanswered)
    assert "3 host line(s) answered" in log and "0 not reached" in log, log
