"""The fuzzer's link (fuzz/link.py) on a wire paced at 115200 baud, in virtual time: a prompt the
pace splits from its fence answer still completes that answer."""
from __future__ import annotations

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.emulator.inprocess_target import InProcessTarget
from buildhat_conformance.fuzz.link import FENCE, Link

EMPTY = {0: None, 1: None, 2: None, 3: None}


def test_fuzz_link_completes_a_prompt_split_by_the_wire() -> None:
    # With echo on the prompt follows the fence answer; on a paced wire it arrives a moment
    # later, and a line still crossing at the fence belongs to the next answer.
    target = InProcessTarget(firmware="R7", devices=EMPTY, baud=115200)
    target.open()
    link = Link(target, "paced")
    link.drain()
    assert isinstance(target.emulator, Emulator) and target.emulator.hat is not None
    fence_line = b"Firmware version: " + target.emulator.hat.version_string.encode() + b"\r\n"
    link.exchange(b"echo 1\r", fence_line, 1)
    answers = link.exchange_batch([b"vin\r", b"port 1\r"], fence_line, [1, 1])
    for answer in answers:
        assert answer.endswith(fence_line + b"P0>") or answer.endswith(fence_line + b"P1>"), answer
    assert answers[0].startswith(b"vin\r\n") and FENCE in answers[0]
