"""The emulator's hung-firmware fault (emulator/hang.py): `@hang`, `--hang-after N`, `?hang_after=N`."""
from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.emulator.hang import HangTrigger
from buildhat_conformance.harness.targets import TargetError, make_target

BIN = pathlib.Path(sys.executable).parent
VERSION = b"Firmware version: "


def booted(**kw) -> Emulator:
    emu = Emulator(firmware="R7", **kw)
    emu.boot()
    emu.advance(50)
    emu.read()
    return emu


def test_the_firmware_hangs_right_after_the_nth_line_until_a_reset():
    emu = booted(hang_after=2)
    emu.write(b"version\rversion\rversion\r")     # the third line reaches a hung firmware
    emu.advance(200)
    assert emu.read().count(VERSION) == 2
    assert emu.world("@firmware") == "ok hung"
    emu.write(b"version\r")
    emu.advance(1000)
    assert emu.read() == b""
    emu.world("@reset")
    emu.advance(3000)
    emu.read()
    emu.write(b"version\r" * 3)                     # once only: the reset ended it for good
    emu.advance(200)
    assert emu.read().count(VERSION) == 3


def test_hang_on_the_control_channel_drops_what_was_queued():
    emu = booted(baud=115200)
    emu.write(b"help\r")
    emu.advance(5)            # the help text is still crossing the wire
    emu.world("@hang")
    emu.advance(2000)
    out = emu.read()
    assert len(out) < 200, out
    with pytest.raises(Exception, match="takes nothing"):
        emu.world("@hang now")


@pytest.mark.parametrize("url, message", [
    ("emulator:?hang_after=x", "hang_after must be an integer"),
    ("inprocess:?hang_after=0", "hang_after must be at least 1 line"),
    ("inprocess:?hang_after=x", "bad option value"),
])
def test_a_bad_hang_option_is_one_line(url, message):
    with pytest.raises(TargetError, match=message) as info:
        make_target(url)
    assert "\n" not in str(info.value)


def test_the_cli_refuses_a_hang_after_below_one():
    proc = subprocess.run([str(BIN / "buildhat-emulator"), "--stdio", "--hang-after", "0"],
                          capture_output=True, text=True, timeout=30)
    assert proc.returncode == 2
    # one line in the program's voice (no usage text before it), pointing at --help
    assert proc.stderr.strip().splitlines() == [
        "buildhat-emulator: --hang-after must be at least 1 line, got 0 (see buildhat-emulator --help)"]


def test_a_hat_that_hangs_mid_answer_is_silent_not_garbled():
    from buildhat_conformance.conformance.target_fault import GARBLED, SILENT, describe_silence
    from buildhat_conformance.harness.line_splitter import LineSplitter

    hat_lines = b"\r\nFirmware version: 1737564117 2025-01-22T16:41:57+00:00\r\n"
    events = LineSplitter().feed(hat_lines, 0.0)
    fault = describe_silence(hat_lines, events, 3.0)
    assert fault.kind == SILENT and "then no answer to `version`" in fault.what
    junk = b"zzzz nonsense\r\n" * 3
    assert describe_silence(junk, LineSplitter().feed(junk, 0.0), 3.0).kind == GARBLED


def test_the_trigger_finds_the_end_of_the_nth_line_across_writes():
    trigger = HangTrigger(3)
    assert trigger.split(b"vin\rport 0") is None            # one line so far
    assert trigger.split(b"\rlist\rversion\r") == 6        # the third CR ends at index 5
    assert trigger.split(b"vin\r") is None                  # once only


def test_never_and_nonsense_counts():
    assert HangTrigger(None).split(b"\r" * 100) is None
    with pytest.raises(ValueError, match="at least 1"):
        HangTrigger(0)
