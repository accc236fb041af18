"""The virtual-time target (serving/virtual_time_target.py) serves any HAT model, not only the
emulator: a model it is given by a factory, and a clear error when it has none."""
from __future__ import annotations

from typing import Any, Callable, Dict, List

import pytest

from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.harness.targets.base import TargetError
from buildhat_conformance.serving.hat_model import HatModel, WorldError
from buildhat_conformance.serving.virtual_time_target import VirtualTimeTarget


class EchoModel:
    """A HAT model of the test's own: echoes what it is sent, one byte a millisecond of HAT time."""

    def __init__(self) -> None:
        self.now = 0
        self._pending = bytearray()
        self._out = bytearray()
        self.booted = False

    def boot(self) -> int:
        self.booted = True
        return 0

    def write(self, data: bytes) -> None:
        self._pending += data

    def read(self) -> bytes:
        out, self._out = bytes(self._out), bytearray()
        return out

    def step(self) -> None:
        self.now += 1
        if self._pending:
            self._out.append(self._pending.pop(0))

    def advance(self, ms: int) -> None:
        for _ in range(ms):
            self.step()

    def world(self, line: str) -> str:
        raise WorldError(f"this model has no world: {line.strip()}")

    def on_event(self, callback: Callable[[Dict[str, Any]], None]) -> None:
        pass


def _factory(made: List[EchoModel]) -> Callable[..., HatModel]:
    def make(**_options: Any) -> HatModel:
        made.append(EchoModel())
        return made[-1]
    return make


def test_a_model_from_a_factory_is_served_in_virtual_time() -> None:
    made: List[EchoModel] = []
    target = VirtualTimeTarget(factory=_factory(made), url="test:echo")
    target.open()
    served = target.emulator
    assert isinstance(served, EchoModel) and served.booted    # a booted copy of the model made
    assert served is not made[0]                               # (the booted one is kept to copy)
    target.write(b"abc")
    got = b""
    while len(got) < 3:
        got += target.read(0.01)         # at most 10 HAT ms a read, the wall clock never read
    assert got == b"abc"
    assert target.now == served.now >= 3


def test_world_actions_reach_the_model_and_its_refusal_is_one_target_error() -> None:
    target = VirtualTimeTarget(factory=_factory([]), url="test:echo")
    target.open()
    with pytest.raises(TargetError, match="@plug 0 0x30: this model has no world"):
        target.control.action("@plug 0 0x30")


def test_without_a_model_the_target_says_so() -> None:
    with pytest.raises(TargetError, match="test:none: no HAT model to serve"):
        VirtualTimeTarget(url="test:none").open()


def test_a_booted_copy_is_never_another_target_kinds() -> None:
    # A booted model is kept per kind of target: an emulator booted for `inprocess:` with the same
    # options must not be served to a kind that has no model of its own (this process once did).
    InProcessTarget(url="inprocess").open()
    with pytest.raises(TargetError, match="no HAT model to serve"):
        VirtualTimeTarget(url="test:none").open()
