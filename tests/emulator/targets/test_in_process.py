"""The in-process target (emulator/targets/in_process.py on serving/virtual_time_target.py): URL,
virtual time, independent copies."""
from __future__ import annotations

import pytest

from buildhat_conformance.emulator.targets.in_process import InProcessTarget, from_url
from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.targets.base import TargetError

EMPTY = {0: None, 1: None, 2: None, 3: None}


def test_url_options():
    t = make_target("inprocess:R5?device=0=0x30&device=2=passive 8&seed=3")
    assert isinstance(t, InProcessTarget)
    assert t.firmware == "R5" and t.seed == 3
    assert t.devices == {0: ("active", 0x30), 2: ("passive", 8)}
    with pytest.raises(TargetError, match="unknown option"):
        from_url("inprocess?speed=3")
    with pytest.raises(TargetError, match="P=SPEC"):
        from_url("inprocess?device=0x30")
    with pytest.raises(TargetError, match="unknown firmware"):
        InProcessTarget("R99", devices=EMPTY).open()


def test_read_advances_virtual_time_only_until_output():
    t = InProcessTarget("R7", devices=EMPTY)
    t.open()
    t.read(0.05)
    start = t.now
    assert t.read(0.2) == b""                      # nothing to say: 200 HAT ms pass
    assert t.now - start == 200
    t.write(b"vin\r")
    assert t.read(1.0) == b"\r\n8.00 V\r\n"         # answered at once: no time passes
    assert t.now - start == 200
    t.advance(5)
    assert t.now - start == 205


def test_opens_are_independent_copies_of_one_boot():
    a = InProcessTarget("R7", devices=EMPTY)
    b = InProcessTarget("R7", devices=EMPTY)
    a.open()
    b.open()
    a.read(0.01)
    b.read(0.01)
    a.write(b"echo 1\rport 2\r")
    assert a.read(0.01) == b"\r\nP0>port 2\r\nP2>"
    # b never saw echo 1: a copy must not share the line editor's view of the echo flag
    b.write(b"vin\r")
    assert b.read(0.01) == b"\r\n8.00 V\r\n"


def test_closed_target_says_so():
    t = InProcessTarget("R7", devices=EMPTY)
    with pytest.raises(TargetError, match="not open"):
        t.write(b"vin\r")
