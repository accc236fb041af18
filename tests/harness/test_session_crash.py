"""Crash safety: whatever dies (the target process, or the run itself), the transcript on disk
holds every byte that was received."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest
from harness_fakehat import HERE as FAKEHAT  # noqa: E402
from target_kinds import make_target_of

from buildhat_conformance.harness.errors import TargetError
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets.cmd import CommandTarget
from buildhat_conformance.harness.transcript import hat_stream, read_transcript

STREAM = 60


def _logged(wrote, suffix: bytes = b"P0>", timeout: float = 10.0) -> bytes:
    """The child's log once it ends with ``suffix``: the child writes a chunk, then logs it,
    so the log can trail what was received by a moment."""
    deadline = time.monotonic() + timeout
    data = b""
    while time.monotonic() < deadline:
        data = wrote.read_bytes() if wrote.exists() else b""
        if data.endswith(suffix):
            break
        time.sleep(0.02)
    return data


def _cmd(wrote: str) -> str:
    return f"cmd:{sys.executable} -u {FAKEHAT} --stdio --stream {STREAM} --wrote {wrote}"


def test_killing_the_target_mid_run_keeps_every_byte(tmp_path):
    wrote, path = tmp_path / "wrote.bin", tmp_path / "t.jsonl"
    target = make_target_of(CommandTarget, _cmd(str(wrote)))
    s = Session(target, transcript=str(path)).open()
    try:
        s.expect(lambda e: e.kind == "mode_data" and e.fields["values"] == [STREAM // 2], 10)
        assert target.proc is not None
        os.killpg(target.proc.pid, signal.SIGKILL)   # mid-stream
        with pytest.raises(TargetError) as info:
            s.expect("error", 10)                     # nothing more will come: the target is gone
        assert "killed by signal 9" in str(info.value)
    finally:
        s.close()
    sent = wrote.read_bytes()
    t = read_transcript(str(path))
    got = t.hat_bytes
    assert got == bytes(s.received)
    # every byte the child wrote is in the transcript; the child logs a chunk only after
    # writing it, so the transcript may hold at most the one chunk it was killed after
    assert got.startswith(sent) and len(got) - len(sent) <= len(f"P0M0: +{STREAM}\r\nP0>")
    assert any("target error" in e.get("text", "") for e in t.of("note"))


def test_a_partial_line_is_kept_when_the_target_dies(tmp_path):
    wrote, path = tmp_path / "wrote.bin", tmp_path / "t.jsonl"
    target = make_target_of(CommandTarget, _cmd(str(wrote)))
    s = Session(target, transcript=str(path)).open()
    try:
        s.expect(lambda e: e.kind == "mode_data" and e.fields["values"] == [STREAM], 10)
        s.expect("prompt", 10)               # the stream ends with P0> and no CRLF
        _logged(wrote)
        assert target.proc is not None
        os.killpg(target.proc.pid, signal.SIGKILL)
        with pytest.raises(TargetError):
            s.expect("error", 10)
    finally:
        s.close()
    t = read_transcript(str(path))
    assert t.hat_bytes == wrote.read_bytes() == bytes(s.received)
    partials = [e for e in t.of("hat") if "partial" in e]
    assert partials and partials[-1]["partial"] == "P0>"


_RUN = textwrap.dedent("""
    import os, signal, sys
    from buildhat_conformance.harness.session import Session
    from buildhat_conformance.harness.targets import make_target
    s = Session(make_target(sys.argv[1]), transcript=sys.argv[2]).open()
    s.expect(lambda e: e.kind == "mode_data" and e.fields["values"] == [int(sys.argv[4])], 10)
    s.expect("prompt", 10)
    if sys.argv[3] == "raise":
        raise RuntimeError("the run crashed")      # uncaught: the interpreter exits with 1
    os.kill(os.getpid(), signal.SIGKILL)         # no clean-up of any kind
""")


@pytest.mark.parametrize("how", ["raise", "sigkill"])
def test_a_crashed_run_leaves_its_transcript(tmp_path, how):
    wrote, path = tmp_path / "wrote.bin", tmp_path / "t.jsonl"
    proc = subprocess.run([sys.executable, "-c", _RUN, _cmd(str(wrote)), str(path), how, str(STREAM)],
                          capture_output=True, timeout=60, start_new_session=True)
    assert proc.returncode == (1 if how == "raise" else -9), proc.stderr.decode()[-2000:]
    events = read_transcript(str(path)).events
    got, sent = hat_stream(events), _logged(wrote)
    if how == "raise":
        # atexit flushed the last output that had no CRLF yet
        assert got == sent
        assert [e for e in events if "partial" in e][-1]["partial"] == "P0>"
    else:
        # killed outright: every complete line is on disk; only the unterminated tail can be lost
        assert sent.startswith(got) and sent[len(got):] in (b"", b"P0>")
        assert f"P0M0: +{STREAM}".encode() in got
