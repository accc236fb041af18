"""The fuzzer's link (fuzz/running/target_exchange.py) on a wire paced at 115200 baud, in virtual time: a
prompt the
pace splits from its fence answer still completes that answer."""
from __future__ import annotations

from types import SimpleNamespace

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.fuzz.running.target_exchange import FENCE, TargetExchange

EMPTY = {0: None, 1: None, 2: None, 3: None}


def test_fuzz_link_completes_a_prompt_split_by_the_wire() -> None:
    # With echo on the prompt follows the fence answer; on a paced wire it arrives a moment
    # later, and a line still crossing at the fence belongs to the next answer.
    target = InProcessTarget(firmware="R7", devices=EMPTY, baud=115200)
    target.open()
    link = TargetExchange(target, "paced")
    link.drain()
    assert isinstance(target.emulator, Emulator) and target.emulator.hat is not None
    fence_line = b"Firmware version: " + target.emulator.hat.version_string.encode() + b"\r\n"
    link.exchange(b"echo 1\r", fence_line, 1)
    answers = link.exchange_batch([b"vin\r", b"port 1\r"], fence_line, [1, 1])
    for answer in answers:
        assert answer.endswith(fence_line + b"P0>") or answer.endswith(fence_line + b"P1>"), answer
    assert answers[0].startswith(b"vin\r\n") and FENCE in answers[0]


class _PlainHat:
    """A virtual target that cannot tell when its command port is at rest."""

    capabilities = frozenset({"virtual_time"})
    time_scale = None

    def __init__(self):
        self.now, self.calls = 0, []

    def advance(self, ms: int) -> None:
        self.now += ms
        self.calls.append(("advance", ms))

    def read(self, timeout: float) -> bytes:
        return b""


class _RestingHat(_PlainHat):
    """One whose command port comes to rest ``rest_ms`` after a settle begins."""

    def __init__(self, rest_ms: int):
        super().__init__()
        self.rest_ms = rest_ms

    def settle(self, min_ms: int, max_ms: int) -> int:
        waited = min(max(min_ms, self.rest_ms), max_ms)
        self.now += waited
        self.calls.append(("settle", min_ms, max_ms))
        return waited


def test_a_pause_ends_when_the_port_is_at_rest_and_the_trace_keeps_what_passed() -> None:
    # A replayed finding waits the trace's @wait in full, so it must be what really passed.
    hat = _RestingHat(rest_ms=40)
    link = TargetExchange(hat, "sil")  # type: ignore[arg-type]
    link.settle(10, 500)
    assert hat.now == 40 and hat.calls == [("settle", 10, 500)]
    assert link.trace.entries[-1] == ("wait", 0.0, 40)


def test_a_target_that_cannot_tell_waits_the_whole_pause() -> None:
    hat = _PlainHat()
    link = TargetExchange(hat, "plain")  # type: ignore[arg-type]
    link.settle(10, 500)
    assert hat.now == 500 and hat.calls == [("advance", 500)]
    assert link.trace.entries[-1] == ("wait", 0.0, 500)


def test_target_now_goes_on_from_link_to_link_of_one_target():
    """What outlives a run on a kept-open target is timed by it (fuzz/oracles/reconnecting.py): each run has a
    TargetExchange of its own, whose ``now`` starts anew on a wall-clock target."""
    hat = _RestingHat(rest_ms=0)
    hat.now = 1234
    assert TargetExchange(hat, "target").target_now == 1234.0  # type: ignore[arg-type]  # virtual: the HAT's clock
    wall = SimpleNamespace(time_scale=10.0, capabilities=frozenset())
    first = TargetExchange(wall, "target")   # type: ignore[arg-type]  # a stand-in: only its clock is read
    at = first.target_now
    second = TargetExchange(wall, "target")  # type: ignore[arg-type]
    # a new link's now starts at 0, the target's clock goes on
    assert second.now < 1000.0 <= at <= second.target_now
