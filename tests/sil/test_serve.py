"""``sil serve`` (sil/serve.py): the real firmware at wall-clock pace on stdio, answering a host as a
HAT does (docs/FIRMWARE-BEHAVIOUR.md#fb-version: `version` prints the release's line), and its bad
options one line with exit 2. Generous deadlines, no timing asserted."""
from __future__ import annotations

import os
import select
import subprocess
import time

import pytest
from sil_support import CLI, cli, firmware_tree

from buildhat_conformance.sil.serve import build_parser

pytestmark = pytest.mark.timeout(600)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("silcache")


def test_served_on_stdio_the_firmware_answers_version(cache):
    tree = firmware_tree()
    built = cli("sil", "build", str(tree), cache=cache)       # built first: the serve starts at once
    assert built.returncode == 0, built.stderr
    env = dict(os.environ, BUILDHAT_SIL_CACHE=str(cache))
    proc = subprocess.Popen(CLI + ["sil", "serve", str(tree), "--stdio", "--booted"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert proc.stdin is not None and proc.stdout is not None
    try:
        proc.stdin.write(b"version\r")
        proc.stdin.flush()
        got, deadline = b"", time.monotonic() + 60
        while b"Firmware version: 1737564117" not in got and time.monotonic() < deadline:
            if select.select([proc.stdout], [], [], 1.0)[0]:
                chunk = os.read(proc.stdout.fileno(), 4096)
                if not chunk:
                    break
                got += chunk
        assert b"Firmware version: 1737564117" in got, got
    finally:
        proc.kill()
        proc.wait()


def test_serve_needs_one_link_mode():
    parser = build_parser()
    with pytest.raises(SystemExit) as exc:
        parser.parse_args(["tree", "--pty", "--stdio"])
    assert exc.value.code == 2


def test_the_served_firmware_keeps_no_event_list(cache, monkeypatch):
    # A serve runs for as long as the host likes: its HAT passes events on but never stores them.
    from buildhat_conformance.sil.hat import SilHat
    from buildhat_conformance.sil.serve import _hat
    tree = firmware_tree()
    assert cli("sil", "build", str(tree), cache=cache).returncode == 0
    monkeypatch.setenv("BUILDHAT_SIL_CACHE", str(cache))
    parser = build_parser()
    hat = _hat(parser.parse_args([str(tree), "--stdio", "--device", "1=0x30"]), parser)
    try:
        assert isinstance(hat, SilHat) and hat.devices[1] is not None
        seen = []
        hat.on_event(seen.append)
        hat.boot()
        assert seen, "the start-up of a motor on port 1 gives device events"
        assert hat.events == []
    finally:
        hat.close()


# -- the wire's pace (issue 39) ----------------------------------------------------------------------------
# docs/FIRMWARE-BEHAVIOUR.md#fb-uart: 115200 baud, 8N1: a byte takes 10 bits, 86.8 us, on the wire.
BYTE_US = 10 / 115200 * 1e6


def _served_hat(cache, monkeypatch, *options: str):
    from buildhat_conformance.sil.serve import _hat
    tree = firmware_tree()
    assert cli("sil", "build", str(tree), cache=cache).returncode == 0
    monkeypatch.setenv("BUILDHAT_SIL_CACHE", str(cache))
    parser = build_parser()
    return _hat(parser.parse_args([str(tree), "--stdio", *options]), parser)


def test_host_bytes_are_taken_no_faster_than_the_wire_carries_them(cache, monkeypatch):
    hat = _served_hat(cache, monkeypatch)
    try:
        hat.boot()
        room = hat.host_room()
        assert room is not None and 0 < room < 200, "a few ms of the wire's bytes, never an unbounded queue"
        hat.write(b"#" * 2000)                  # a comment line's bytes (no CR): nothing runs, nothing prints
        assert hat.host_room() == 0, "2000 bytes take 174 ms on the wire: no room until they have crossed it"
        hat.advance(int(2000 * BYTE_US / 1000) - 20)      # 20 ms before the last of them arrives
        assert hat.host_room() == 0
        hat.advance(40)                        # all across, the wire idle again
        assert hat.host_room() == room
    finally:
        hat.close()


def test_the_control_channel_names_the_version_the_firmware_reports(cache, monkeypatch):
    hat = _served_hat(cache, monkeypatch)
    try:
        # asked before the start-up is done: the copy it is asked of finishes its own
        assert hat.world("@firmware") == "ok 1737564117 2025-01-22T16:41:57+00:00"
        hat.boot()
        hat.read()
        hat.write(b"vi")                       # a line the host has not finished: the answer must not mix in
        hat.advance(5)
        hat._version = None                    # noqa: SLF001 - asked again, now with a line half typed
        assert hat.world("@firmware") == "ok 1737564117 2025-01-22T16:41:57+00:00"
        hat.write(b"n\r")
        hat.advance(50)
        out = hat.read()
        assert b"V\r\n" in out and b"Firmware version" not in out, out   # the host's own `vin`, and only it
    finally:
        hat.close()
