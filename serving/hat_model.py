"""What the serving kit needs of a HAT model: the emulator (emulator/api.py), a firmware in the loop
(sil/hat.py) or an emulated chip (rp2040/chip.py) all offer it, so the kit serves any of them."""
from __future__ import annotations

from typing import Any, Callable, Dict, Protocol, Union

__all__ = ["HatModel", "WorldError", "DeviceSpec"]

DeviceSpec = Union[None, str, tuple]      # as the script's ``@device`` (protocol/devices.py)


class HatModel(Protocol):
    """What a virtual-time target (serving/virtual_time_target.py) and the real-time loop use of a
    HAT model: ``Emulator`` (emulator/api.py), ``SilHat`` (sil/hat.py), or a planted fault wrapping
    one (tests/planted/)."""

    @property
    def now(self) -> int: ...

    def boot(self) -> int: ...

    def write(self, data: bytes) -> None: ...

    def read(self) -> bytes: ...

    def step(self) -> None: ...

    def advance(self, ms: int) -> None: ...

    def world(self, line: str) -> str: ...

    def on_event(self, callback: Callable[[Dict[str, Any]], None]) -> None: ...


class WorldError(RuntimeError):
    """A world action the HAT model cannot perform (or that failed)."""
