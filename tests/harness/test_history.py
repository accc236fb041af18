"""Nothing lost, memory bounded (issue 13, item 7): the session keeps only the recent past in
memory while the transcript on disk keeps every byte; a half line waiting for its CRLF reaches
the file as it arrives, so even a kill -9 of the harness loses none of it; every case of the
suite gets a transcript file of its own.

Real parts: ``cmd:`` programs as targets, a harness in a child process killed with SIGKILL.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from buildhat_conformance.conformance.plugin.run import transcript_name
from buildhat_conformance.harness.history import MAX_EVENTS, ByteHistory, EventHistory
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.transcript import read_transcript

pytestmark = pytest.mark.timeout(120)


def test_event_history_forgets_the_oldest_and_keeps_absolute_positions() -> None:
    h: EventHistory[int] = EventHistory(limit=100)
    h.extend(list(range(1000)))
    assert len(h) == 1000                       # positions count everything ever added
    assert h.dropped >= 1000 - 125 and len(h._items) <= 125
    assert h[999] == 999 and h[-1] == 999
    assert h[990:1000] == list(range(990, 1000))
    assert h[0:5] == []                         # long gone: an empty slice, not wrong items
    with pytest.raises(IndexError, match="no longer kept"):
        _ = h[0]
    assert h.scan(lambda x: x % 7 == 0 and x > 950, 0) == 952


def test_event_history_is_bounded_by_weight_too() -> None:
    h: EventHistory[bytes] = EventHistory(limit=10_000, weigh=len, max_weight=10_000)
    for _ in range(100):
        h.append(b"x" * 1000)
    assert sum(len(x) for x in h._items) <= 10_000
    assert len(h) == 100


def test_byte_history_keeps_offsets_after_forgetting() -> None:
    b = ByteHistory(limit=1000)
    for k in range(100):
        b += b"%04d|" % k * 10          # 50 bytes a time, 5,000 in all
    assert len(b) == 5000 and b.dropped > 0 and len(b._data) <= 1250
    assert b[4950:4955] == b"0099|"
    assert b.find(b"0099|", 4900) >= 4900
    with pytest.raises(IndexError):
        _ = b[0]


FLOOD_LINES = MAX_EVENTS * 13 // 10      # past the bound (it trims a quarter at a time)


def _program(tmp_path, name: str, body: str) -> str:
    path = tmp_path / name
    path.write_text("import os, sys, time\nout = sys.stdout.buffer\n" + body)
    return f"cmd:{sys.executable} {path}"


def test_a_flood_keeps_session_memory_bounded_and_the_transcript_complete(tmp_path) -> None:
    url = _program(tmp_path, "flood.py",
                   f"for k in range({FLOOD_LINES}):\n    out.write(b'FLOOD %06d\\r\\n' % k)\n"
                   "out.write(b'P0>')\nout.flush()\ntime.sleep(60)\n")
    path = tmp_path / "flood.jsonl"
    session = Session(make_target(url), transcript=str(path))
    session.open(detect=False)
    try:
        deadline = time.monotonic() + 60
        while session.events[-1:] == [] or session.events[-1].text != "P0>":
            assert time.monotonic() < deadline, "the flood did not arrive"
            time.sleep(0.05)
        # The reader thread trims its history after adding a chunk; its lock says it is done.
        session.mark()
        # Every line counted, but only the recent past kept.
        assert len(session.events) == FLOOD_LINES + 1
        assert session.events.dropped > 0 and len(session.events._items) <= MAX_EVENTS * 5 // 4
        assert session.events[-2].text == f"FLOOD {FLOOD_LINES - 1:06d}"
    finally:
        session.close()
    lines = [e["line"] for e in read_transcript(str(path)).events if e.get("dir") == "hat" and "line" in e]
    assert lines == [f"FLOOD {k:06d}" for k in range(FLOOD_LINES)], "the transcript lost lines"


HARNESS = """
import sys, time
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target
session = Session(make_target(sys.argv[1]), transcript=sys.argv[2])
session.open(detect=False)
while not session.received.endswith(b"P0>"):
    time.sleep(0.01)
print("received", flush=True)
time.sleep(60)
"""


def test_kill_9_of_the_harness_loses_no_half_line(tmp_path) -> None:
    url = _program(tmp_path, "prompt.py", "out.write(b'hello\\r\\nP0>')\nout.flush()\ntime.sleep(60)\n")
    path = tmp_path / "killed.jsonl"
    harness = subprocess.Popen([sys.executable, "-c", HARNESS, url, str(path)], stdout=subprocess.PIPE,
                               start_new_session=True)
    try:
        assert harness.stdout is not None
        assert harness.stdout.readline().strip() == b"received"
        # The half line goes to disk once it has waited PARTIAL_MAX_AGE (0.1 s) for its CRLF.
        deadline = time.monotonic() + 10
        while b'"partial":"P0>"' not in (path.read_bytes() if path.exists() else b"") \
                and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        os.killpg(harness.pid, signal.SIGKILL)     # the harness and the target it started
        harness.wait()
    events = read_transcript(str(path)).events
    assert {"line": "hello"}.items() <= next(e for e in events if e.get("dir") == "hat").items()
    assert any(e.get("partial") == "P0>" for e in events), events


def test_transcript_names_are_unique_per_case() -> None:
    a = transcript_name("test_separators.py::test_two_commands[vin;vin]")
    b = transcript_name("test_separators.py::test_two_commands[vin ; vin]")
    c = transcript_name("test_separators.py::test_two_commands[vin  ;  vin]")
    assert len({a, b, c}) == 3
    assert transcript_name("test_link.py") == "test_link.py"       # a safe name stays as it is
    long_ids = [f"test_x.py::test_y[{'a' * 300}{k}]" for k in range(3)]
    names = [transcript_name(n) for n in long_ids]
    assert len(set(names)) == 3 and all(len(n) <= 181 for n in names)
    assert all(os.sep not in n and "[" not in n for n in names + [a, b, c])
