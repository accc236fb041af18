"""A sync finds its own reply by content (harness/sync.py). The bytes it sends are fed to the in-process
emulator, and its answer must have the shape docs/FIRMWARE-BEHAVIOUR.md#fb-line gives: with echo on every
stored byte is echoed, a NUL ends what the parser reads, so the token's line comes back whole, then
CRLF, then `version`'s line; `echo 0` ran, so no prompt follows and echo stays off."""
from __future__ import annotations

import re

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.harness.sync import SEPARATE_TAIL, new_token, sync_bytes

NO_ECHO_VIN = re.compile(rb"\r\n\d+\.\d\d V\r\n")     # the CR's CRLF, then the reading (fb-vin)


def _booted() -> Emulator:
    emu = Emulator(firmware="R7", devices={0: None, 1: None, 2: None, 3: None})
    emu.boot()
    emu.advance(50)
    emu.read()
    return emu


def _answer(emu: Emulator, data: bytes) -> bytes:
    emu.write(data)
    emu.advance(20)
    return emu.read()


def test_tokens_differ():
    assert new_token() != new_token()


def test_the_tokens_line_comes_back_whole_then_version_and_echo_is_left_off():
    emu = _booted()
    token = new_token()
    out = _answer(emu, sync_bytes(token))
    head, _, tail = out.partition(b"echo 0 ; version\x00" + token)
    assert tail.startswith(b"\r\nFirmware version: 1737564117") and not tail.rstrip().endswith(b">"), out
    assert NO_ECHO_VIN.fullmatch(_answer(emu, b"vin\r"))     # echo off: no echo, no prompt


def test_the_one_command_a_line_form_ends_with_its_echo_0():
    emu = _booted()
    token = new_token()
    out = _answer(emu, sync_bytes(token, separate=True))
    assert b"version\x00" + token + b"\r\nFirmware version: 1737564117" in out, out
    assert out.rstrip(b"\r\n").endswith(SEPARATE_TAIL), out
    assert NO_ECHO_VIN.fullmatch(_answer(emu, b"vin\r"))
