"""``Rp2040Hat``: a release's ``firmware.bin`` on the emulated chip, driven as sil drives a HAT.

The runner (``runner.mjs``, Node.js with rp2040js) speaks the frames of the firmware in the loop
(``sil/frames.py``), so :class:`~..sil.hat.SilHat` drives it unchanged and the world around it is
sil's (``sil/port_world.py``: the emulator's device models, fault latches, Vin). What the runner does
not have: copies of a running chip (Node cannot fork; every open boots a new chip), and the ports'
UARTs at the pins (its PIO is not yet run on the simulation clock), so only passive devices and
empty ports are wired.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, Mapping, Optional

from ..emulator.world_actions import WorldError
from ..protocol.devices import parse_device_spec
from ..sil.hat import SilHat
from .install import runner_command

__all__ = ["Rp2040Hat", "EMPTY_PORTS", "unwired_ports", "unwired_plug"]

#: The chip starts with nothing on its ports (the firmware then reports passive ID 4 on each).
EMPTY_PORTS: Dict[int, Any] = {0: None, 1: None, 2: None, 3: None}


def unwired_ports(devices: Mapping[int, Any]) -> Dict[int, Any]:
    """The ports whose device needs its UART at the chip's pins (an active device): not yet wired."""
    return {p: spec for p, spec in devices.items() if isinstance(spec, tuple) and spec[0] == "active"}


def unwired_plug(line: str) -> bool:
    """``@plug P SPEC`` of a device whose UART is not yet wired to the chip's pins."""
    words = line.split()
    if words[:1] != ["@plug"] or len(words) < 3:
        return False
    try:
        return bool(unwired_ports({0: parse_device_spec(" ".join(words[2:]))}))
    except ValueError:
        return False


class Rp2040Hat(SilHat):
    def __init__(self, image: Path, bootrom: Path, devices: Optional[Mapping[int, Any]] = None, seed: int = 0,
                 features: Optional[Mapping[str, Any]] = None, signature: Optional[bytes] = None,
                 record_events: bool = True, version: str = "unknown"):
        self.version = version            # what the image's `version` prints after "Firmware version: "
        command = runner_command(image, bootrom)
        self.program_args = command[1:]
        layout = dict(EMPTY_PORTS)
        layout.update(devices or {})
        super().__init__(command[0], devices=layout, seed=seed, features=features, signature=signature,
                         record_events=record_events)

    def world(self, line: str) -> str:
        words = line.split()
        if words[:1] == ["@firmware"]:
            # (sil's answer asks a copy of the HAT; a chip here cannot be copied: the image's release
            # says what its `version` prints)
            return "ok dead" if self.died is not None else "ok hung" if self.hung else f"ok {self.version}"
        if words[:2] == ["@reset", "bootloader"]:
            raise WorldError("@reset bootloader: the HAT's bootloader is not on the emulated chip "
                             "(the rp2040: target starts the image as the bootloader does)")
        return super().world(line)

    def copy(self) -> SilHat:
        raise RuntimeError("a chip on rp2040js cannot be copied (each open boots a new one)")
